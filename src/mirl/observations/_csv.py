"""CSV plumbing shared by the grid and pose readers: the header, pyarrow reading and writing on
one thread, and the file line of a data row (for messages; only on the error path)."""

from __future__ import annotations

import codecs
from collections.abc import Iterator
from pathlib import Path

import numpy as np

BLOCK_BYTES = 1 << 22


HEADER_BYTES = 1 << 16  # a header is read up to this many characters


def _first_line(path: Path) -> str:
    """The file's first line (up to :data:`HEADER_BYTES`), a UTF-8 BOM dropped. Decoded alone:
    a text-mode read decodes a whole buffer, so a byte that is not UTF-8 on a later line would
    be blamed on the header. Raises OSError and UnicodeDecodeError."""
    with open(path, "rb") as fh:
        raw = fh.readline(HEADER_BYTES)
    # final=False: a character cut by the byte limit is no decoding error
    return codecs.getincrementaldecoder("utf-8-sig")().decode(raw, final=False)


def csv_header(path: Path, error) -> list[str]:
    """The stripped, unquoted header names; ``error`` for a missing, unreadable or empty file,
    or one that is not UTF-8 text."""
    try:
        first = _first_line(path)  # a UTF-8 BOM is accepted
    except FileNotFoundError:
        raise error(f"{path}: no such file") from None
    except UnicodeDecodeError as exc:
        raise error(f"{path}: line 1: {not_text(exc)}") from None
    except OSError as exc:
        raise error(f"{path}: cannot read ({exc.strerror or exc})") from None
    if not first.strip():
        raise error(f"{path}: file is empty")
    return [h.strip().strip('"') for h in first.strip("\r\n").split(",")]


def not_text(exc: UnicodeDecodeError) -> str:
    """Why a file that failed to decode is no CSV, in words rather than the codec's."""
    return f"not UTF-8 text (byte 0x{exc.object[exc.start]:02x} at offset {exc.start}), so no CSV"


class NotText(ValueError):
    """A line of a file that is not UTF-8 text: its 1-based number and the decoding error."""

    def __init__(self, line: int, exc: UnicodeDecodeError) -> None:
        super().__init__(f"line {line}: {not_text(exc)}")
        self.line, self.exc = line, exc


def text_lines(path: Path) -> Iterator[str]:
    """The file's lines decoded one by one (a UTF-8 BOM dropped), for ``csv.reader``; raises
    :class:`NotText` naming the first line that is not UTF-8."""
    with open(path, "rb") as fh:
        for lineno, raw in enumerate(fh, start=1):
            try:
                yield raw.decode("utf-8-sig" if lineno == 1 else "utf-8")
            except UnicodeDecodeError as exc:
                raise NotText(lineno, exc) from None


def is_text(path: Path) -> bool:
    """Whether the start of ``path`` decodes as UTF-8 (an image or an archive does not). A file
    that cannot be opened counts as text: :func:`csv_header` then says why it cannot be read."""
    try:
        _first_line(path)
    except UnicodeDecodeError:
        return False
    except OSError:
        return True
    return True


def repeated_column(header: list[str]) -> str | None:
    """The first column name the header repeats (which of the two a reader would take cannot
    be known), or None."""
    return next((h for k, h in enumerate(header) if h in header[:k]), None)


def arrow_read(path: Path, header: list[str], columns: dict):
    """Read ``columns`` (name -> arrow type) of a CSV whose stripped header is ``header`` (pyarrow
    would keep the spaces of `` robot``). Raises pyarrow's errors: callers decide the message."""
    import pyarrow.csv as pv

    return pv.read_csv(
        path,
        read_options=pv.ReadOptions(
            use_threads=False, block_size=BLOCK_BYTES, column_names=header, skip_rows=1
        ),
        convert_options=pv.ConvertOptions(
            column_types=columns, include_columns=list(columns), strings_can_be_null=False
        ),
    )


def write_columns(
    path: str | Path, columns: dict[str, np.ndarray], robot: np.ndarray, names: tuple[str, ...]
) -> None:
    """Write a CSV (plain header, no quoting) with pyarrow: ``columns`` in order, the column
    named ``robot`` (its value in ``columns`` is ignored) filled with ``names[robot]``."""
    import pyarrow as pa
    import pyarrow.csv as pv

    labels = pa.DictionaryArray.from_arrays(
        pa.array(np.asarray(robot, dtype=np.int32)), pa.array(list(names) or [""], pa.string())
    ).cast(pa.string())
    table = pa.table({k: (labels if k == "robot" else v) for k, v in columns.items()})
    with open(path, "wb") as fh:
        fh.write((",".join(columns) + "\n").encode())
        pv.write_csv(table, fh, pv.WriteOptions(include_header=False, quoting_style="none"))


def data_line_numbers(path: Path) -> np.ndarray:
    """1-based file line of each data row as pyarrow counts them (empty lines skipped)."""
    lines = []
    with open(path, "rb") as fh:
        next(fh, None)  # header
        for lineno, line in enumerate(fh, start=2):
            if line.strip(b"\r\n"):
                lines.append(lineno)
    return np.asarray(lines, dtype=np.int64)
