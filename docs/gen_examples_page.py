"""Write the site's page of the repository's examples (run by mkdocs-gen-files).

The page is ``examples/README.md`` (what each example shows, how to run it), its links to the
scripts turned into links to their sections below, followed by every file of every example folder
as a code block: the site shows the scripts as they are in the repository, nothing is copied by hand.
"""

from __future__ import annotations

import re
from pathlib import Path

import mkdocs_gen_files

REPOSITORY = Path(__file__).resolve().parents[1]
EXAMPLES = REPOSITORY / "examples"
LANGUAGES = {".sh": "bash", ".py": "python", ".yaml": "yaml"}


def section(folder: Path) -> str:
    """One example folder: each of its files, by path, as a code block."""
    lines = [f"## `{folder.name}/`\n"]
    for path in sorted(p for p in folder.rglob("*") if p.is_file() and p.suffix in LANGUAGES):
        lines += [
            f"`examples/{path.relative_to(EXAMPLES)}`\n",
            f"```{LANGUAGES[path.suffix]}",
            path.read_text().rstrip(),
            "```\n",
        ]
    return "\n".join(lines)


def page() -> str:
    readme = (EXAMPLES / "README.md").read_text()
    folders = sorted(p for p in EXAMPLES.iterdir() if p.is_dir())
    # (own_robot/run.sh) → (#own_robot), (environment.sh) → (#environmentsh): sections of this page.
    readme = re.sub(r"\]\((\w+)/[\w./]*\)", lambda m: f"](#{m.group(1)})", readme)
    readme = readme.replace("](environment.sh)", "](#environmentsh)")
    readme = readme.replace(
        "# Examples\n", "# Examples\n\nThe repository's `examples/` folder, as it is.\n", 1
    )
    environment = "\n".join(
        ["## `environment.sh`\n", "```bash", (EXAMPLES / "environment.sh").read_text().rstrip(), "```\n"]
    )
    return readme.rstrip() + "\n\n" + environment + "\n" + "\n".join(section(f) for f in folders)


with mkdocs_gen_files.open("examples.md", "w") as out:
    out.write(page())
