"""Screenshots of MLflow's UI for the README's comparison walk-through, taken in headless Chromium.

The script follows the walk-through as a reader would:

1. runs the README's sweep ``lwrlab -m hydra/launcher=parallel task=identification
   estimator=ols,wls,sdp seed=0,1`` into a temporary SQLite store (shortened motions unless
   ``--full``), then ``lwrlab compare --experiment identification`` on it;
2. starts ``mlflow server`` on 127.0.0.1 and a free port;
3. drives headless Chromium over the DevTools protocol on a pipe (no debugging port is opened) and
   captures, at 1400×900:

   - ``mlflow_runs.png``: the experiment's runs table, the sweep expanded, with the Dataset column and
     ``estimator``, ``seed``, ``accuracy/rms_mean``,
     ``accuracy/base_parameter_error``, the sweep's ``summary/best_rms_mean`` and the comparison run's
     ``estimator:wls/rms_mean``;
   - ``mlflow_runs_grouped.png``: the same runs grouped by ``estimator`` (averages over seeds);
   - ``mlflow_compare.png``: the compare-runs page of the six job runs;

4. stops the server and writes the PNGs into ``docs/images/``.

MLflow's UI keeps the runs page's columns, widths, sort and grouping per experiment in the browser's
local storage; the script merges its choices into that state (the store is only read). MLflow 3's
sidebar switch (GenAI | Model training) is set by ``?workflowType=machine_learning``: without it, a
fresh browser opens an experiment on the GenAI overview whatever ``mlflow.experimentKind`` says.
The compare page is shown as it opens (its plot's axes are chosen in the page).

Needs ``chromium`` on PATH (Debian: ``apt-get install chromium``)::

    .venv/bin/python docs/screenshots.py                       # ~1 min on 2 cores
    .venv/bin/python docs/screenshots.py --full                # the README's sweep as is
    .venv/bin/python docs/screenshots.py --tracking-uri sqlite:///outputs/mlflow.db   # an existing store
"""

from __future__ import annotations

import argparse
import base64
import contextlib
import fcntl
import json
import os
import select
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.parse
import urllib.request
from collections.abc import Iterator
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
IMAGES = REPO_ROOT / "docs" / "images"
EXPERIMENT = "identification"
SWEEP = ["hydra/launcher=parallel", "task=identification", "estimator=ols,wls,sdp", "seed=0,1"]
# Shorter motions: the same sweep in about a third of the time, the same columns and groups.
SHORT_MOTIONS = ["trajectory=multisine", "trajectory.duration=4", "validation.duration=4"]
WINDOW = (1400, 900)
MAX_PNG_BYTES = 300_000
COLUMNS = [
    "params.`estimator`",
    "params.`seed`",
    "metrics.`accuracy/rms_mean`",
    "metrics.`accuracy/base_parameter_error`",
    "metrics.`summary/best_rms_mean`",
    "metrics.`estimator:wls/rms_mean`",
]


def run_sweep(store: Path, full: bool) -> str:
    """Run the README's sweep into a SQLite store under ``store``; return its tracking URI.

    Parameters
    ----------
    store : Path
        Folder for the store, its artifacts and the sweep's output folders.
    full : bool
        Run the sweep exactly as the README shows it (the optimised exciting motion, 20 s validation).
    """
    uri = f"sqlite:///{store / 'mlflow.db'}"
    command = [
        sys.executable,
        "-m",
        "lwrlab.cli",
        "-m",
        *SWEEP,
        *([] if full else SHORT_MOTIONS),
        "plant.show_progress=false",
        f"tracking.uri={uri}",
        f"tracking.artifact_location={store / 'mlartifacts'}",
        f"hydra.sweep.dir={store / 'multirun'}",
    ]
    print("sweep:", " ".join(command[3:]), flush=True)
    completed = subprocess.run(command, cwd=REPO_ROOT, capture_output=True, text=True)
    if completed.returncode != 0:
        raise SystemExit(f"the sweep failed:\n{completed.stderr[-3000:]}")
    return uri


def run_compare(uri: str, output: Path) -> None:
    """``lwrlab compare --experiment identification`` on the store; prints its table."""
    command = [
        sys.executable,
        "-m",
        "lwrlab.cli",
        "compare",
        "--experiment",
        EXPERIMENT,
        "--tracking-uri",
        uri,
        "--output",
        str(output),
    ]
    completed = subprocess.run(command, cwd=REPO_ROOT, capture_output=True, text=True)
    if completed.returncode != 0:
        raise SystemExit(f"lwrlab compare failed:\n{completed.stderr[-3000:]}")
    print(completed.stdout, flush=True)


def free_port() -> int:
    """A TCP port free on 127.0.0.1 at the time of asking."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@contextlib.contextmanager
def mlflow_server(
    uri: str, log: Path, timeout_s: float = 120.0, port: int | None = None, subcommand: str = "server"
) -> Iterator[str]:
    """Serve the store with ``mlflow server`` (or ``mlflow ui``: ``subcommand``) on 127.0.0.1 only, on
    ``port`` (None: a free one); yield its base URL, stop it and its workers after."""
    port = free_port() if port is None else port
    mlflow = Path(sys.executable).with_name("mlflow")
    command = [
        str(mlflow),
        subcommand,
        "--host",
        "127.0.0.1",
        "--port",
        str(port),
        "--workers",
        "1",
        "--backend-store-uri",
        uri,
    ]
    with log.open("w") as log_file:
        # A session of its own, so that stopping it also stops the workers it forks.
        server = subprocess.Popen(command, stdout=log_file, stderr=subprocess.STDOUT, start_new_session=True)
    base_url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + timeout_s
        while True:
            if server.poll() is not None:
                raise SystemExit(f"mlflow server exited:\n{log.read_text()[-3000:]}")
            with contextlib.suppress(OSError):
                with urllib.request.urlopen(f"{base_url}/health", timeout=2) as response:
                    if response.status == 200:
                        break
            if time.monotonic() > deadline:
                raise SystemExit(f"mlflow server did not answer within {timeout_s:.0f} s")
            time.sleep(0.5)
        yield base_url
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(server.pid, 15)
        try:
            server.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(server.pid, 9)
            server.wait()


class HeadlessChromium:
    """Headless Chromium driven over the DevTools protocol on a pipe (fds 3 and 4, no socket).

    Parameters
    ----------
    executable : str
        The chromium binary.
    profile : Path
        A fresh user-data folder (local storage starts empty).
    """

    def __init__(self, executable: str, profile: Path) -> None:
        to_browser_read, to_browser_write = os.pipe()
        from_browser_read, from_browser_write = os.pipe()
        # Move the browser's ends above 3 and 4 first, so that wiring them onto 3 and 4 cannot clobber them.
        browser_in = fcntl.fcntl(to_browser_read, fcntl.F_DUPFD, 10)
        browser_out = fcntl.fcntl(from_browser_write, fcntl.F_DUPFD, 10)
        os.close(to_browser_read)
        os.close(from_browser_write)

        def wire_pipes() -> None:
            os.dup2(browser_in, 3)
            os.dup2(browser_out, 4)

        command = [
            executable,
            "--headless=new",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--no-first-run",
            "--remote-debugging-pipe",
            f"--user-data-dir={profile}",
            f"--window-size={WINDOW[0]},{WINDOW[1]}",
            "about:blank",
        ]
        self.process = subprocess.Popen(
            command,
            pass_fds=(3, 4),
            preexec_fn=wire_pipes,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        os.close(browser_in)
        os.close(browser_out)
        self._write_fd = to_browser_write
        self._read_fd = from_browser_read
        self._buffer = b""
        self._next_id = 0
        self.session = ""

    def send(self, method: str, params: dict | None = None, timeout_s: float = 60.0) -> dict:
        """Send one command (to the page's session once attached) and return its result."""
        self._next_id += 1
        message = {"id": self._next_id, "method": method, "params": params or {}}
        if self.session:
            message["sessionId"] = self.session
        os.write(self._write_fd, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + timeout_s
        while True:
            while b"\0" not in self._buffer:
                remaining = deadline - time.monotonic()
                if remaining <= 0 or not select.select([self._read_fd], [], [], remaining)[0]:
                    raise TimeoutError(f"no answer to {method} within {timeout_s:.0f} s")
                chunk = os.read(self._read_fd, 1 << 20)
                if not chunk:
                    raise RuntimeError("chromium closed the DevTools pipe")
                self._buffer += chunk
            raw, self._buffer = self._buffer.split(b"\0", 1)
            reply = json.loads(raw)
            if reply.get("id") == self._next_id:  # events and other sessions' traffic are not needed
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})

    def open_page(self) -> None:
        """Open a tab of the window's size and attach to it."""
        target = self.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        self.session = self.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        self.send(
            "Emulation.setDeviceMetricsOverride",
            {"width": WINDOW[0], "height": WINDOW[1], "deviceScaleFactor": 1, "mobile": False},
        )

    def evaluate(self, expression: str) -> object:
        """The value of a JavaScript expression in the page."""
        result = self.send("Runtime.evaluate", {"expression": expression, "returnByValue": True})
        return result.get("result", {}).get("value")

    def show(self, url: str, ready_texts: list[str], timeout_s: float = 90.0) -> None:
        """Load ``url`` and wait until the page's text holds every one of ``ready_texts``."""
        self.send("Page.navigate", {"url": "about:blank"})  # a real load, not a hash change
        self.send("Page.navigate", {"url": url})
        condition = " && ".join(
            f"document.body.innerText.includes({json.dumps(text)})" for text in ready_texts
        )
        deadline = time.monotonic() + timeout_s
        while not self.evaluate(f"Boolean(document.body) && {condition}"):
            if time.monotonic() > deadline:
                text = self.evaluate("document.body ? document.body.innerText.slice(0, 2000) : ''")
                raise SystemExit(
                    f"{url} did not show {ready_texts} within {timeout_s:.0f} s; it shows:\n{text}"
                )
            time.sleep(0.5)
        # MLflow 3 opens its assistant panel beside the page: close it to leave the room to the runs.
        self.evaluate(
            "document.querySelector('[data-component-id=\"mlflow.assistant.chat_panel.close\"]')?.click()"
        )
        time.sleep(2.0)  # let the grid lay its columns out and charts finish animating

    def update_local_storage(self, key: str, values: dict) -> None:
        """Merge ``values`` into the JSON object kept under ``key`` in the page's local storage."""
        self.evaluate(
            f"localStorage.setItem({json.dumps(key)}, JSON.stringify("
            f"Object.assign(JSON.parse(localStorage.getItem({json.dumps(key)}) || '{{}}'), {json.dumps(values)})))"
        )

    def screenshot(self, path: Path) -> None:
        """Write the viewport as a PNG."""
        data = self.send("Page.captureScreenshot", {"format": "png"})["data"]
        path.write_bytes(base64.b64decode(data))

    def close(self) -> None:
        """Close the browser and the pipes."""
        with contextlib.suppress(Exception):
            self.session = ""
            self.send("Browser.close", timeout_s=10)
        try:
            self.process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        os.close(self._write_fd)
        os.close(self._read_fd)


def view_state_key(experiment_id: str) -> str:
    """The local-storage key under which MLflow's UI keeps an experiment's runs-page view."""
    return f'MLflowLocalStorage-1.1-ExperimentPage-["{experiment_id}"]-ReactComponentState'


def shrink_png(path: Path) -> None:
    """Quantise a screenshot to a 256-colour palette when it is over the size limit."""
    if path.stat().st_size <= MAX_PNG_BYTES:
        return
    from PIL import Image

    with Image.open(path) as image:
        image.convert("RGB").quantize(colors=256).save(path, optimize=True)


def take_screenshots(uri: str, browser: HeadlessChromium, base_url: str, output: Path) -> list[Path]:
    """Capture the runs table, the grouped runs and the compare page of the experiment."""
    from mlflow import MlflowClient

    client = MlflowClient(tracking_uri=uri)
    experiment = client.get_experiment_by_name(EXPERIMENT)
    if experiment is None:
        raise SystemExit(f"no experiment {EXPERIMENT!r} in {uri}")
    runs = client.search_runs([experiment.experiment_id], "attributes.status = 'FINISHED'")
    jobs = [run for run in runs if "estimator" in run.data.params and "accuracy/rms_mean" in run.data.metrics]
    parents = {run.data.tags.get("mlflow.parentRunId") for run in jobs} - {None}
    if not jobs:
        raise SystemExit(f"no finished identification run in {EXPERIMENT!r}")
    runs_url = f"{base_url}/#/experiments/{experiment.experiment_id}/runs?workflowType=machine_learning"
    estimators = sorted({run.data.params["estimator"] for run in jobs})
    browser.open_page()
    # The first visit lets the UI write its own view state (its default columns, Dataset among them);
    # the views below are merged into it.
    browser.show(runs_url, ["matching runs"])
    key = view_state_key(experiment.experiment_id)
    default = browser.evaluate(f"JSON.parse(localStorage.getItem({json.dumps(key)}) || '{{}}')")
    # Of the default columns only Dataset says something here (Source, Models and Duration are empty or
    # noise): the headline metrics then fit in the window beside it.
    default_columns = [c for c in (default or {}).get("selectedColumns") or [] if "Dataset" in c]
    table_view = {
        "selectedColumns": default_columns + COLUMNS,
        "runsExpanded": {parent: True for parent in parents},
        "orderByKey": "params.`estimator`",
        "orderByAsc": True,
    }
    grouped_view = {
        **table_view,
        "groupBy": {
            "aggregateFunction": "average",
            "groupByKeys": [{"mode": "param", "groupByData": "estimator"}],
        },
    }
    table_view["groupBy"] = None
    written = []
    for name, view, ready in [
        (
            "mlflow_runs.png",
            table_view,
            ["matching runs", "accuracy/base_parameter_error", jobs[0].info.run_name[:12]],
        ),
        (
            "mlflow_runs_grouped.png",
            grouped_view,
            ["matching runs", "accuracy/base_parameter_error", f"Group: {estimators[0]}"],
        ),
    ]:
        browser.update_local_storage(key, view)
        browser.show(runs_url, ready)
        browser.screenshot(output / name)
        written.append(output / name)
    run_ids = json.dumps([run.info.run_id for run in sorted(jobs, key=lambda run: run.info.run_name)])
    compare_url = (
        f"{base_url}/#/compare-runs?runs={urllib.parse.quote(run_ids)}"
        f"&experiments={urllib.parse.quote(json.dumps([experiment.experiment_id]))}"
    )
    browser.show(compare_url, ["Comparing", "Parallel Coordinates Plot", "Run details"])
    browser.screenshot(output / "mlflow_compare.png")
    written.append(output / "mlflow_compare.png")
    for path in written:
        shrink_png(path)
    return written


def main(argv: list[str] | None = None) -> None:
    """Run the walk-through and write its screenshots."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tracking-uri", help="an existing store holding the sweep (skips the sweep)")
    parser.add_argument(
        "--full", action="store_true", help="run the README's sweep without shortened motions"
    )
    parser.add_argument(
        "--output", type=Path, default=IMAGES, help="folder for the PNGs (default docs/images)"
    )
    parser.add_argument(
        "--chromium",
        default=shutil.which("chromium") or shutil.which("chromium-browser"),
        help="the chromium binary (default: from PATH)",
    )
    args = parser.parse_args(argv)
    if not args.chromium:
        raise SystemExit("chromium not found: apt-get install chromium, or give --chromium PATH")
    args.output.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="lwrlab-screenshots-") as scratch:
        scratch_dir = Path(scratch)
        uri = args.tracking_uri
        if uri is None:
            uri = run_sweep(scratch_dir / "store", args.full)
            run_compare(uri, scratch_dir / "compare")
        with mlflow_server(uri, scratch_dir / "server.log") as base_url:
            browser = HeadlessChromium(args.chromium, scratch_dir / "profile")
            try:
                written = take_screenshots(uri, browser, base_url, args.output)
            finally:
                browser.close()
    for path in written:
        print(
            f"{path.relative_to(REPO_ROOT) if path.is_relative_to(REPO_ROOT) else path}: "
            f"{path.stat().st_size / 1000:.0f} kB"
        )


if __name__ == "__main__":
    main()
