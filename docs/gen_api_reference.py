"""Write the API reference pages, one per module of ``lwrlab`` and ``plugins`` (run by mkdocs-gen-files).

The modules are found by walking the packages as Python imports them, so a module that moves or is
split shows up under its new dotted name at the next build; nothing lists them by hand. Each page is
one ``::: dotted.name`` directive that mkdocstrings renders from the numpy-style docstrings.
``lwrlab.conf`` (the config tree, a link to ``conf/``) is described by the configuration reference.
"""

from __future__ import annotations

import importlib
import pkgutil

import mkdocs_gen_files

PACKAGES = ("lwrlab", "plugins")
SKIPPED = ("lwrlab.conf",)
"""Packages whose modules get no API page (with everything below them)."""


def module_names(package: str) -> list[str]:
    """``package`` and every module below it, sorted, without the skipped ones."""
    root = importlib.import_module(package)
    names = [package] + [m.name for m in pkgutil.walk_packages(root.__path__, prefix=f"{package}.")]
    return sorted(n for n in names if not any(n == s or n.startswith(f"{s}.") for s in SKIPPED))


def main() -> None:
    navigation = mkdocs_gen_files.Nav()
    for package in PACKAGES:
        for name in module_names(package):
            parts = tuple(name.split("."))
            page = "/".join(parts) + ".md"
            navigation[parts] = page
            with mkdocs_gen_files.open(f"reference/api/{page}", "w") as out:
                out.write(f"# `{name}`\n\n::: {name}\n")
    with mkdocs_gen_files.open("reference/api/SUMMARY.md", "w") as out:
        out.writelines(navigation.build_literate_nav())


main()
