"""Reading a shipped data file by name, or a user's file by path, with one-line errors."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

MAX_FILE_BYTES = 64 * 2**20  # a map or scenario file larger than this is refused unread


def shipped_names(folder: str, suffix: str) -> list[str]:
    root = resources.files("mirl") / "data" / folder
    return sorted(p.name.removesuffix(suffix) for p in root.iterdir() if p.name.endswith(suffix))


def read_shipped_or_file(
    name_or_path: str | Path,
    folder: str,
    suffix: str,
    error: type[Exception],
    kind: str,
    *,
    known: str = "",
) -> tuple[str, str, Path | None]:
    """(text, source label, path or None if shipped). Errors name the file and say what
    shipped names exist, so a typo in a name is as clear as a missing file; ``known``, if
    given, is that list instead of this folder's ``suffix`` files (a map may be a ROS one)."""
    name = str(name_or_path)
    shipped = shipped_names(folder, suffix)
    listed = known or ", ".join(shipped)
    if not name.strip():  # Path("") is ".", which would be read as a directory
        raise error(f"an empty {kind} name (shipped {kind}s: {listed})")
    if name in shipped:
        res = resources.files("mirl") / "data" / folder / f"{name}{suffix}"
        return res.read_text(), f"{name} (shipped)", None
    path = Path(name_or_path)
    try:
        if path.is_file() and path.stat().st_size > MAX_FILE_BYTES:
            size = path.stat().st_size / 2**20
            raise error(f"{path}: {size:.0f} MB is larger than the limit of 64 MB for a {kind}")
        # a device or pipe (/dev/zero, <(cat ...)) has no size to check first: read one byte
        # past the limit at most
        with path.open("rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
        if len(data) > MAX_FILE_BYTES:
            raise error(f"{path}: more than the limit of 64 MB for a {kind}")
        # a BOM (Windows editors write one) is dropped, as in a CSV; line ends as read_text's
        text = data.decode("utf-8-sig").replace("\r\n", "\n").replace("\r", "\n")
        return text, str(path), path
    except FileNotFoundError:
        raise error(f"{path}: no such file (shipped {kind}s: {listed})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{path}: cannot read {kind} ({exc.__class__.__name__}: {exc})") from None
