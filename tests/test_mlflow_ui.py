"""A sweep's runs in MLflow's UI as a person sees them, in headless Chromium (slow, needs ``chromium``).

A sweep of two estimators (2 s motions), then ``lwrlab compare`` on it; ``mlflow ui`` serves the store
on 127.0.0.1 and a free port, passed to ``lwrlab compare --ui-port``; the browser opens the link
``lwrlab compare`` printed, with the headline columns chosen as the README shows (written into the
browser's local storage, where the UI keeps them), and the test reads the rendered page's text: the run
names, the datasets they were fitted on and the comparison run's headline metric. The screenshot stays
in the test's temporary folder (its path is printed).

The browser is Debian's ``chromium`` (``.ci/run`` installs it), driven over the DevTools protocol on a
pipe by ``docs/screenshots.py``'s driver: no browser is downloaded, no debugging port opened.
"""

from __future__ import annotations

import importlib.util
import json
import re
import shutil
from pathlib import Path
from types import ModuleType

import pytest
from tracking_apps import REPO_ROOT, jobs_and_parents, run_app, runs_of

pytestmark = pytest.mark.slow
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
EXPERIMENT = "ui_sweep"
SWEEP = [
    "task=identification",
    "estimator=ols,wls",
    "trajectory=multisine",
    "trajectory.duration=2",
    "validation.duration=2",
    "plant.show_progress=false",
    f"experiment_name={EXPERIMENT}",
]
STARTUP_TIMEOUT_S = 120


def _driver() -> ModuleType:
    """``docs/screenshots.py``, whose ``HeadlessChromium`` drives the browser."""
    spec = importlib.util.spec_from_file_location(
        "lwrlab_docs_screenshots", REPO_ROOT / "docs" / "screenshots.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.skipif(CHROMIUM is None, reason="needs Debian's chromium on PATH (apt-get install chromium)")
def test_a_sweep_and_its_comparison_read_at_a_glance_in_the_runs_table(tmp_path: Path) -> None:
    assert CHROMIUM is not None
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    swept = run_app(
        None, *SWEEP, f"hydra.sweep.dir={tmp_path / 'sweep'}", store=tmp_path, multirun=True, timeout=600
    )
    assert swept.returncode == 0, swept.stderr[-3000:]
    driver = _driver()  # docs/screenshots.py: the browser and the server it looks at
    port = driver.free_port()
    compared = run_app(
        None,
        "compare",
        "--tracking-uri",
        uri,
        "--experiment",
        EXPERIMENT,
        "--ui-port",
        str(port),
        "--output",
        str(tmp_path / "compare"),
        cwd=tmp_path,
    )
    assert compared.returncode == 0, compared.stderr[-3000:]
    link = re.search(r"then open (http://127\.0\.0\.1:(\d+)/\S+)", compared.stdout)
    assert link is not None and int(link.group(2)) == port, compared.stdout  # the port passed

    runs = runs_of(uri, EXPERIMENT)
    jobs, parents = jobs_and_parents(runs)
    (comparison,) = [run for run in runs if run.data.tags.get("run_kind") == "compare"]
    assert len(jobs) == 2 and len(parents) == 1
    assert all(len(run.data.params) <= 30 for run in jobs)
    assert parents[0].data.metrics["summary/jobs"] == 2  # the sweep's row is not empty
    experiment_id = jobs[0].info.experiment_id
    datasets = {i.dataset.name for run in jobs for i in run.inputs.dataset_inputs}
    assert datasets == {"multisine_motion", "multisine_validation_motion"}
    compared_key = "estimator:wls/rms_mean"
    compared_value = comparison.data.metrics[compared_key]
    assert compared_value == pytest.approx(
        next(run.data.metrics["accuracy/rms_mean"] for run in jobs if run.data.params["estimator"] == "wls")
    )

    with driver.mlflow_server(uri, tmp_path / "ui.log", STARTUP_TIMEOUT_S, port=port, subcommand="ui"):
        browser = driver.HeadlessChromium(CHROMIUM, tmp_path / "profile")
        try:
            browser.open_page()
            browser.show(link.group(1), ["matching runs"])  # the UI writes its own view state first
            # The README's steps: expand the sweep, tick the headline columns (jobs' and comparison's).
            key = driver.view_state_key(experiment_id)
            default = browser.evaluate(f"JSON.parse(localStorage.getItem({json.dumps(key)}) || '{{}}')")
            columns = [
                "params.`estimator`",
                "metrics.`accuracy/rms_mean`",
                "metrics.`summary/best_rms_mean`",
                f"metrics.`{compared_key}`",
            ]
            default_columns = list((default or {}).get("selectedColumns") or [])  # Dataset, Duration, …
            view = {
                "selectedColumns": default_columns + columns,
                "runsExpanded": {parents[0].info.run_id: True},
            }
            browser.update_local_storage(key, view)
            names = [run.info.run_name for run in jobs] + [comparison.info.run_name]
            browser.show(link.group(1), ["matching runs", compared_key, *names])
            text = str(browser.evaluate("document.body.innerText"))
            screenshot = tmp_path / "mlflow_runs.png"
            browser.screenshot(screenshot)
        finally:
            browser.close()
    print(f"screenshot: {screenshot}")
    assert all(name in text for name in names)
    assert "multisine_motion" in text  # the Dataset column: what each job was fitted on
    assert "accuracy/rms_mean" in text and "summary/best_rms_mean" in text
    shown = {float(value) for value in re.findall(r"\b0\.\d+\b", text)}
    assert any(abs(value - compared_value) <= 0.0015 for value in shown), (compared_value, text[-2000:])
    assert screenshot.stat().st_size > 10_000
