"""A sweep's runs in MLflow's UI as a colleague sees them from the printed link (slow, needs ``chromium``).

A sweep of two estimators (2 s motions), then ``lwrlab compare`` on it; ``mlflow ui`` serves the store
on 127.0.0.1 and a free port, passed to ``lwrlab compare --ui-port``. A browser with a fresh profile
(nothing in its local storage, and nothing written there by the test) opens exactly the link
``lwrlab compare`` printed, the link the sweep's end printed too, and, without a click, the runs
table shows each job's headline metrics as MLflow read them back (compared as the page prints them),
grouped by estimator with the better one first, and the sweep's and the comparison's runs; the chart
view of the same link starts with the ``accuracy`` section. Where the jobs logged their identified
model, the Models column links each to it. The screenshot stays in the test's temporary folder (its
path is printed).

The browser is Debian's ``chromium`` (``.ci/run`` installs it), driven over the DevTools protocol on a
pipe by ``docs/screenshots.py``'s driver: no browser is downloaded, no debugging port opened.
"""

from __future__ import annotations

import importlib.util
import json
import re
import shutil
import time
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from mlflow.tracking import MlflowClient
from tracking_apps import REPO_ROOT, jobs_and_parents, run_app, runs_of

from lwrlab.tracking.job_config.naming import HEADLINE_METRICS

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
    "tracking.register_model=robot",  # each job's model a version of the robot's registered model
    f"experiment_name={EXPERIMENT}",
]
STARTUP_TIMEOUT_S = 120
LINK = re.compile(r"MLflow UI: .*?, then open (http://127\.0\.0\.1:(\d+)(/\S+))")


def _driver() -> ModuleType:
    """``docs/screenshots.py``, whose ``HeadlessChromium`` drives the browser."""
    spec = importlib.util.spec_from_file_location(
        "lwrlab_docs_screenshots", REPO_ROOT / "docs" / "screenshots.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def driver_base(link: re.Match[str]) -> str:
    """The server's address in a printed link."""
    return f"http://127.0.0.1:{link.group(2)}"


def as_the_page_prints(value: float) -> str:
    """A metric as MLflow's runs table prints it: JavaScript's shortest round-trip decimal form.

    Examples
    --------
    >>> as_the_page_prints(0.4909737818796377), as_the_page_prints(2.0), as_the_page_prints(1e-05)
    ('0.4909737818796377', '2', '0.00001')
    """
    return np.format_float_positional(value, trim="-") if 1e-6 <= abs(value) < 1e21 else repr(value)


@pytest.mark.skipif(CHROMIUM is None, reason="needs Debian's chromium on PATH (apt-get install chromium)")
def test_the_printed_link_opens_the_jobs_headline_metrics_in_a_fresh_browser(tmp_path: Path) -> None:
    assert CHROMIUM is not None
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    swept = run_app(
        None, *SWEEP, f"hydra.sweep.dir={tmp_path / 'sweep'}", store=tmp_path, multirun=True, timeout=600
    )
    assert swept.returncode == 0, swept.stderr[-3000:]
    at_sweep_end = LINK.search(swept.stdout + swept.stderr)  # mlflow ui's default port
    assert at_sweep_end is not None and at_sweep_end.group(2) == "5000", swept.stdout[-3000:]
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
    link = LINK.search(compared.stdout)
    assert link is not None and int(link.group(2)) == port, compared.stdout  # the port passed
    assert "viewStateShareKey=" in link.group(3) and link.group(3) == at_sweep_end.group(3)  # one view

    runs = runs_of(uri, EXPERIMENT)
    jobs, parents = jobs_and_parents(runs)
    (comparison,) = [run for run in runs if run.data.tags.get("run_kind") == "compare"]
    assert len(jobs) == 2 and len(parents) == 1
    assert parents[0].data.metrics["summary/jobs"] == 2  # the sweep's row is not empty
    experiment_id = jobs[0].info.experiment_id
    # the headline metrics the jobs logged (an identification logs no excitation metric): the view's columns
    headline = [
        f"accuracy/{metric}"
        for metric in HEADLINE_METRICS
        if all(f"accuracy/{metric}" in run.data.metrics for run in jobs)
    ]
    assert "accuracy/rms_mean" in headline and "accuracy/base_parameter_error" in headline
    shown = {
        run.data.params["estimator"]: [as_the_page_prints(run.data.metrics[key]) for key in headline]
        for run in jobs
    }
    by_error = sorted(jobs, key=lambda run: run.data.metrics["accuracy/rms_mean"])
    best, worst = (run.data.params["estimator"] for run in by_error)
    client = MlflowClient(uri)
    logged_models = {
        model.source_run_id: model.model_id for model in client.search_logged_models([experiment_id])
    }
    assert set(logged_models) == {run.info.run_id for run in jobs}  # one model per job
    (registered,) = client.search_registered_models()
    versions = sorted(
        int(version.version) for version in client.search_model_versions(f"name = '{registered.name}'")
    )
    assert versions == [1, 2]
    names = [run.info.run_name for run in [*jobs, *parents, comparison]]

    with driver.mlflow_server(uri, tmp_path / "ui.log", STARTUP_TIMEOUT_S, port=port, subcommand="ui"):
        browser = driver.HeadlessChromium(CHROMIUM, tmp_path / "profile")  # a new, empty profile
        try:
            browser.open_page()
            browser.show(link.group(1), ["matching runs", *headline, *shown[best], *shown[worst]])
            text = str(browser.evaluate("document.body.innerText"))
            screenshot = tmp_path / "mlflow_runs.png"
            browser.screenshot(screenshot)
            browser.resize(2600, 900)  # the grid draws only the columns in sight: Models is further right
            time.sleep(2.0)
            wide = str(browser.evaluate("document.body.innerText"))
            model_links = {
                model_id: browser.evaluate(
                    f"document.querySelectorAll('a[href$={json.dumps('/models/' + model_id)}]').length"
                )
                for model_id in logged_models.values()
            }
            browser.resize()
            browser.show(f"{link.group(1)}&compareRunsMode=CHART", headline, ready_script=driver.CHARTS_DRAWN)
            charts = str(browser.evaluate("document.body.innerText"))
            browser.show(f"{driver_base(link)}/#/models/{registered.name}", ["Version 1"])
            registry = str(browser.evaluate("document.body.innerText"))
        finally:
            browser.close()
    print(f"screenshot: {screenshot}")
    assert "You're viewing a shared view" in text  # the view saved on the experiment, not the browser's
    assert all(name[:40] in text for name in names), text[-3000:]  # jobs, the sweep, the comparison
    for estimator, values in shown.items():  # every headline metric of every job, as MLflow holds it
        assert all(value in text for value in values), (estimator, values, text[-3000:])
    assert text.index(f"Group: {best}") < text.index(f"Group: {worst}")  # sorted best first
    assert "multisine_motion" in wide  # the Dataset column: what each job was fitted on
    sections = re.findall(r"^(\S[^\n]*)\n\(\d+\)$", charts, flags=re.M)  # "accuracy\n(6)", …
    assert sections and sections[0] == "accuracy", charts[:3000]
    assert all(count > 0 for count in model_links.values()), model_links  # the Models column
    assert all(f"Version {version}" in registry for version in versions), registry[-2000:]
    assert screenshot.stat().st_size > 10_000
