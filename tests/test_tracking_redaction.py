"""Secret-named config keys are redacted everywhere they are logged; other keys are left alone.

A Hypothesis property over generated key names (keyword, case, separators, prefixes and suffixes),
and one real Hydra job whose overrides carry four kinds of secrets.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

from hypothesis import assume, given
from hypothesis import strategies as st
from tracking_apps import TOY_APP, all_logged_text, run_app, runs_of

from lwrlab.tracking.job_config.redaction import (
    REDACTED,
    Redactor,
    is_secret_key,
    redact_secret_assignments,
    redact_secret_params,
    secret_values_in,
)

KEYWORDS = ("password", "passwd", "secret", "token", "api_key", "apikey", "auth", "credential", "private_key")
SEPARATORS = ("_", ".", "-")
WORD = st.text(alphabet="abcdefghijklmnopqrstuvwxyz0123456789", min_size=0, max_size=6)
# A value with no secret keyword, no separator the patterns stop at, at least 4 characters.
VALUE = st.text(alphabet="ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789!%", min_size=4, max_size=16).filter(
    lambda text: not re.search(r"(?i)pass|secret|token|key|auth|cred", text)
)


@st.composite
def secret_keys(draw: st.DrawFn) -> str:
    """``[prefix.]<word><sep><KeyWord><sep><word>``: the keyword in any case, split by any separator."""
    keyword = draw(st.sampled_from(KEYWORDS))
    separator = draw(st.sampled_from(SEPARATORS))
    if ("_" in keyword and separator != ".") or ("_" in keyword and draw(st.booleans())):
        keyword = keyword.replace("_", separator)  # api-key, private.key, ...
    cased = "".join(c.upper() if draw(st.booleans()) else c for c in keyword)
    head, tail = draw(WORD), draw(WORD)
    last = "_".join(part for part in (head, cased, tail) if part) if "." in cased else f"{head}{cased}{tail}"
    parents = draw(st.lists(st.sampled_from(["db", "aws", "mlflow", "service", "x1"]), max_size=3))
    return ".".join([*parents, last])


NOT_SECRET_KEYS = (
    "robot.dof",
    "seed",
    "plant.torque_noise_std",
    "trajectory.harmonics",
    "secret_sauce.count",
    "tracking.uri",
)


@given(key=secret_keys(), value=VALUE, prefix=st.sampled_from(["", "+", "++", "~"]))
def test_every_generated_secret_key_is_redacted_in_every_form(key: str, value: str, prefix: str) -> None:
    assume(value.lower() not in key.lower())  # the key's own name stays readable
    assert is_secret_key(key)
    assert redact_secret_params({key: value, "seed": "3"}) == {key: REDACTED, "seed": "3"}
    override = f"{prefix}{key}={value}"
    assert value not in redact_secret_assignments(f"x=1 {override} seed=2")
    assert redact_secret_assignments(f"x=1 {override} seed=2").endswith("seed=2")
    parent, _, last = key.rpartition(".")
    yaml_text = f"{parent or 'db'}:\n  {last}: {value}\n  user: me\n"
    json_text = json.dumps({"overrides": [override], last: value})
    texts = (yaml_text, json_text, f"override_dirname: {override},seed=2")
    if is_secret_key(last):  # not so for `api.key`: nested YAML shows only `key:`
        for text in texts:
            assert value not in redact_secret_assignments(text), text
    redactor = Redactor.from_config({key: value}, environ={})  # knows the value: catches it in any form
    for text in (*texts, f"a log line that prints {value} alone"):
        assert value not in redactor.redact(text) and redactor.needs_redaction(text.encode()), text


@given(value=VALUE)
def test_keys_without_a_secret_word_keep_their_values(value: str) -> None:
    assert not any(is_secret_key(key) for key in NOT_SECRET_KEYS)
    params = {key: value for key in NOT_SECRET_KEYS}
    assert redact_secret_params(params) == params
    text = " ".join(f"{key}={value}" for key in NOT_SECRET_KEYS)
    assert redact_secret_assignments(text) == text and not secret_values_in(text)


def test_sweep_values_and_interpolations() -> None:
    assert secret_values_in("+db.auth_token=aaaa,bbbb seed=0,1") == {"aaaa", "bbbb", "aaaa,bbbb"}
    assert (
        redact_secret_assignments("password: ${oc.env:DB_PASSWORD}") == "password: ${oc.env:DB_PASSWORD}"
    )  # a name, not a value
    assert redact_secret_assignments("+db.token=abcd,seed=1") == f"+db.token={REDACTED},seed=1"


SECRETS = {
    "+db.auth_token": "tok3nValue9",
    "+db_password": "pw9Value77",
    "+client_secret": "cl1entValue",
    "+aws.secret_access_key": "AKIAVALUE42",
    "+service.API-Key": "ap1Value55",
}


def test_secret_overrides_reach_no_param_tag_name_or_artifact(tmp_path: Path) -> None:
    job_dir = tmp_path / "run"
    overrides = [f"{key}={value}" for key, value in SECRETS.items()]
    finished = run_app(
        TOY_APP, "experiment_name=secret_keys", f"hydra.run.dir={job_dir}", *overrides, store=tmp_path
    )
    assert finished.returncode == 0, finished.stderr
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    (run,) = runs_of(uri, "secret_keys")
    assert run.data.params["db.auth_token"] == REDACTED and run.data.params["client_secret"] == REDACTED
    assert "+db.auth_token=" in run.data.tags["overrides"]
    logged = all_logged_text(uri, run, tmp_path / "download")
    assert ".hydra" in str(list((tmp_path / "download").rglob("*")))
    for value in SECRETS.values():
        assert value not in logged, value
        assert value not in finished.stdout + finished.stderr
    typed = (job_dir / ".hydra" / "overrides.yaml").read_text()
    assert all(value in typed for value in SECRETS.values())  # the local run folder keeps the config as typed
