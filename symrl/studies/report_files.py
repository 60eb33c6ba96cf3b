"""What RESULTS.md is built from: a study's result files read, its figures copied into
``docs/figures``, and the commit its numbers were measured at."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any


def load_json(path: Path) -> Any | None:
    return json.loads(path.read_text()) if path.is_file() else None


def copy_figure(src: Path, figures: Path, name: str) -> str:
    """Copy a figure into docs/figures and return its Markdown image link (or a note)."""
    if not src.is_file():
        return f"*(figure {src} not produced yet)*"
    figures.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(src, figures / name)
    return f"![{name}](docs/figures/{name})"


def measured_at(*records: dict[str, Any] | None) -> str:
    """The commit (and version) the numbers of a section were measured at, from the
    ``provenance`` its result files record; every distinct one when they differ."""
    seen: list[str] = []
    for record in records:
        info = (record or {}).get("provenance") or {}
        if not info.get("revision"):
            continue
        text = f"`{info['revision']}`" + (" with uncommitted changes" if info.get("dirty") else "")
        text += f" (symrl {info['symrl']})" if info.get("symrl") else ""
        if text not in seen:
            seen.append(text)
    if not seen:
        return "Measured at: the result files record no commit."
    return "Measured at commit " + ", ".join(seen) + "."
