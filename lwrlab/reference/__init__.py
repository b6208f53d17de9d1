"""Published figures the lab compares itself with, shipped as package data.

``paper_results.yaml`` holds every number reported by Katsumata et al., RAS 2019 (Tables II-IV, Fig. 6
and the set-up of each experiment), copied from the paper; nothing in it was fitted.
"""

from __future__ import annotations

from functools import cache
from importlib import resources
from typing import Any

import yaml


@cache
def paper_results() -> dict[str, Any]:
    """The paper's reported figures (``paper_results.yaml``), read once."""
    text = resources.files(__package__).joinpath("paper_results.yaml").read_text()
    return yaml.safe_load(text)
