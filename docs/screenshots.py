"""Screenshots of MLflow's UI for the README's comparison walk-through, taken in headless Chromium.

The script follows the walk-through as a reader would:

1. runs the README's sweep ``lwrlab -m hydra/launcher=parallel task=identification
   estimator=ols,wls,sdp seed=0,1`` into a temporary SQLite store (shortened motions unless
   ``--full``), then ``lwrlab compare --experiment identification --ui-port <port>`` on it, which
   saves its view of the runs on the experiment and prints the link that opens it;
2. starts ``mlflow server`` on 127.0.0.1 and that port;
3. drives headless Chromium over the DevTools protocol on a pipe (no debugging port is opened), with
   a new profile, and captures, at 1400×900, what the printed link opens without a click:

   - ``mlflow_runs_grouped.png``: the runs table grouped by ``estimator`` (averages over seeds,
     the best estimator first), the swept ``estimator`` and ``seed`` and the headline metrics
     (``accuracy/rms_mean``, ``accuracy/nrms_mean``, …, the sweep's ``summary/best_rms_mean``);
   - ``mlflow_charts.png``: the chart view of the same link, the ``accuracy`` section first;
   - ``mlflow_compare.png``: the compare-runs page of the six job runs;

4. stops the server and writes the PNGs into ``docs/images/``.

Nothing is written into the browser's local storage: the columns, sort and grouping come from the view
``lwrlab compare`` saved (:mod:`lwrlab.tracking.runs.runs_view`), as they would in a colleague's
browser. With ``--tracking-uri`` the sweep is skipped and ``lwrlab compare --no-log`` saves the view
on the existing store (its only write there). The link carries ``workflowType=machine_learning``:
without it, a new browser opens an experiment on MLflow 3's GenAI overview whatever
``mlflow.experimentKind`` says. The compare page is shown as it opens (its plot's axes are chosen in
the page).

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
import re
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
CHARTS_DRAWN = "document.querySelectorAll('.js-plotly-plot .bars').length >= 3"
"""True once the chart view has drawn the bars of its first row of charts."""


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


def run_compare(uri: str, output: Path, ui_port: int, log_run: bool) -> str:
    """``lwrlab compare --experiment identification`` on the store; prints its table, returns its link.

    ``log_run``: log the comparison as a run (``False``: ``--no-log``, for an existing store).
    """
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
        "--ui-port",
        str(ui_port),
        *([] if log_run else ["--no-log"]),
    ]
    completed = subprocess.run(command, cwd=REPO_ROOT, capture_output=True, text=True)
    if completed.returncode != 0:
        raise SystemExit(f"lwrlab compare failed:\n{completed.stderr[-3000:]}")
    print(completed.stdout, flush=True)
    link = re.search(r"^MLflow UI: .*then open (http://\S+)$", completed.stdout, flags=re.M)
    if link is None:
        raise SystemExit(f"lwrlab compare printed no link to MLflow's UI:\n{completed.stdout[-3000:]}")
    return link.group(1)


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
        self.resize()

    def evaluate(self, expression: str) -> object:
        """The value of a JavaScript expression in the page."""
        result = self.send("Runtime.evaluate", {"expression": expression, "returnByValue": True})
        return result.get("result", {}).get("value")

    def show(
        self, url: str, ready_texts: list[str], timeout_s: float = 90.0, ready_script: str = "true"
    ) -> None:
        """Load ``url`` and wait until the page's text holds every one of ``ready_texts`` and the
        JavaScript expression ``ready_script`` is true (charts drawn, say)."""
        self.send("Page.navigate", {"url": "about:blank"})  # a real load, not a hash change
        self.send("Page.navigate", {"url": url})
        condition = " && ".join(
            [f"document.body.innerText.includes({json.dumps(text)})" for text in ready_texts] or ["true"]
        )
        deadline = time.monotonic() + timeout_s
        while not self.evaluate(f"Boolean(document.body) && {condition} && Boolean({ready_script})"):
            if time.monotonic() > deadline:
                text = self.evaluate("document.body ? document.body.innerText.slice(-4000) : ''")
                raise SystemExit(
                    f"{url} did not show {ready_texts} ({ready_script}) within {timeout_s:.0f} s; "
                    f"its text ends:\n{text}"
                )
            time.sleep(0.5)
        # MLflow 3 opens its assistant panel beside the page: close it to leave the room to the runs.
        self.evaluate(
            "document.querySelector('[data-component-id=\"mlflow.assistant.chat_panel.close\"]')?.click()"
        )
        time.sleep(2.0)  # let the grid lay its columns out and charts finish animating

    def resize(self, width: int = WINDOW[0], height: int = WINDOW[1]) -> None:
        """Lay the page out at ``width`` × ``height`` pixels (the window's size by default)."""
        self.send(
            "Emulation.setDeviceMetricsOverride",
            {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False},
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


def shrink_png(path: Path) -> None:
    """Quantise a screenshot to a 256-colour palette when it is over the size limit."""
    if path.stat().st_size <= MAX_PNG_BYTES:
        return
    from PIL import Image

    with Image.open(path) as image:
        image.convert("RGB").quantize(colors=256).save(path, optimize=True)


def take_screenshots(uri: str, browser: HeadlessChromium, link: str, output: Path) -> list[Path]:
    """Capture what ``link`` (printed by ``lwrlab compare``) opens: the runs, their charts; and the
    compare page of the experiment's job runs."""
    from mlflow import MlflowClient

    client = MlflowClient(tracking_uri=uri)
    experiment = client.get_experiment_by_name(EXPERIMENT)
    if experiment is None:
        raise SystemExit(f"no experiment {EXPERIMENT!r} in {uri}")
    runs = client.search_runs([experiment.experiment_id], "attributes.status = 'FINISHED'")
    jobs = [run for run in runs if "estimator" in run.data.params and "accuracy/rms_mean" in run.data.metrics]
    if not jobs:
        raise SystemExit(f"no finished identification run in {EXPERIMENT!r}")
    best = min(jobs, key=lambda run: run.data.metrics["accuracy/rms_mean"]).data.params["estimator"]
    browser.open_page()
    written = []
    for name, url, ready, drawn in [
        ("mlflow_runs_grouped.png", link, ["matching runs", "accuracy/rms_mean", f"Group: {best}"], "true"),
        ("mlflow_charts.png", f"{link}&compareRunsMode=CHART", ["accuracy/nrms_mean"], CHARTS_DRAWN),
    ]:
        browser.show(url, ready, ready_script=drawn)
        browser.screenshot(output / name)
        written.append(output / name)
    base_url = link.split("/#/", 1)[0]
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
        port = free_port()
        link = run_compare(uri, scratch_dir / "compare", port, log_run=args.tracking_uri is None)
        with mlflow_server(uri, scratch_dir / "server.log", port=port):
            browser = HeadlessChromium(args.chromium, scratch_dir / "profile")  # a new profile
            try:
                written = take_screenshots(uri, browser, link, args.output)
            finally:
                browser.close()
    for path in written:
        print(
            f"{path.relative_to(REPO_ROOT) if path.is_relative_to(REPO_ROOT) else path}: "
            f"{path.stat().st_size / 1000:.0f} kB"
        )


if __name__ == "__main__":
    main()
