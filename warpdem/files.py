"""Writing results files safely: every file goes to a temporary file of a unique name in the same folder and is
renamed over its target when complete, so a killed run never leaves a truncated file and two runs never write into
one temporary file."""

from __future__ import annotations

import os
import uuid
from collections.abc import Callable
from pathlib import Path


def write_atomic(path: str | os.PathLike, write: Callable[[Path], None]) -> None:
    """Call ``write(tmp)`` to write the whole file at a temporary path beside ``path`` (same suffix, so numpy's
    savers keep the name), then rename it to ``path``; the temporary file is removed if ``write`` fails."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp{path.suffix}")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_text_atomic(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` through :func:`write_atomic`."""
    write_atomic(path, lambda tmp: tmp.write_text(text))
