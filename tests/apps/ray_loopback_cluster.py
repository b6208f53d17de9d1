"""TEST HELPER: a two-node Ray cluster (a head and one worker node) on this machine, on 127.0.0.1 only.

Prints ``address <gcs address>`` then ``worker-raylet <pid>`` (the worker node's raylet, for a test
that loses that node) once both nodes are up, keeps the cluster until its stdin closes, then stops
it. Ray binds to loopback only when it does not treat the machine as part of a cluster network
(``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0``, set here before Ray is imported); its
``cluster_utils.Cluster`` then starts both nodes' raylets on 127.0.0.1 (``ray start`` would replace
127.0.0.1 by the network interface's address)::

    python tests/apps/ray_loopback_cluster.py <temp_dir>
"""

from __future__ import annotations

import os
import sys

os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"
os.environ["RAY_USAGE_STATS_ENABLED"] = "0"

from ray._private import ray_constants
from ray.cluster_utils import Cluster


def main(temp_dir: str) -> None:
    # Ray writes the head's address to $RAY_TMPDIR/ray/ray_current_cluster (default /tmp/ray), a folder
    # it creates only for a node using that default: kept inside this cluster's folder, made here
    os.environ["RAY_TMPDIR"] = temp_dir
    os.makedirs(os.path.join(temp_dir, "ray"), exist_ok=True)
    cluster = Cluster(
        initialize_head=True,
        head_node_args={
            "num_cpus": 1,
            "include_dashboard": False,
            "node_ip_address": "127.0.0.1",
            "temp_dir": temp_dir,
        },
    )
    worker = cluster.add_node(num_cpus=1, node_ip_address="127.0.0.1")
    cluster.wait_for_nodes()
    (raylet,) = worker.all_processes[ray_constants.PROCESS_TYPE_RAYLET]
    print(f"address {cluster.address}", flush=True)
    print(f"worker-raylet {raylet.process.pid}", flush=True)
    sys.stdin.read()  # until the test closes the pipe
    cluster.shutdown()


if __name__ == "__main__":
    main(sys.argv[1])
