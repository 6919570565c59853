"""Reading users' text files: byte-order marks and encodings handled in one place.

Windows editors save text with a byte-order mark: Notepad's "UTF-8" writes EF BB BF before the
first character (which TOML and CSV parsers then see as part of the first key or cell), and its
"Unicode" writes UTF-16 with FF FE. Both are accepted here; anything else must be UTF-8, except
where a caller names a fallback (CutPro writes Windows-1252 text, e.g. a "µm/N" label as byte B5).
"""

from __future__ import annotations

import codecs
import csv
import math
import re
from collections.abc import Iterable, Iterator
from pathlib import Path

from millstab.errors import InputError

_BOMS = ((codecs.BOM_UTF8, "utf-8-sig"), (codecs.BOM_UTF16_LE, "utf-16"), (codecs.BOM_UTF16_BE, "utf-16"))


def looks_like(text: str) -> str | None:
    """What a text that failed to parse as the expected kind looks like, for the error message, or ``None``: a
    points or cuts CSV (its first line a header naming rpm), JSON (it opens with ``{``), or a TOML config (a
    ``[cutting]`` table). The commands' arguments go in order (CONFIG CUTS; POSTERIOR CUTS), and one swapped
    said only "TOML syntax error: Expected '=' after a key" or "not valid JSON: Expecting value"."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        return None
    first = lines[0].lstrip("\ufeff")
    if "," in first and "rpm" in [c.strip().lower() for c in first.split(",")]:
        return f"a points or cuts CSV (header {first[:60]!r})"
    if first.startswith("{"):
        return "JSON (a posterior, fit or result file)"
    if any(ln.startswith("[cutting]") for ln in lines):
        return "a TOML config ([cutting] table)"
    return None


def read_text(path: Path, field: str, what: str = "text file", fallback: str | None = None) -> str:
    """The text of ``path`` without a byte-order mark (UTF-8 or UTF-16 with BOM, else UTF-8).

    Args:
        path: an existing file.
        field: names the input in an error (e.g. ``"config"``, ``"--rpm-file"``).
        what: what the file should be, for the error message (``"UTF-8 text (TOML) file"``).
        fallback: an encoding to try when the bytes are not UTF-8 (``"cp1252"``), or ``None``.

    Raises:
        InputError: the file cannot be read, or is not text in an accepted encoding.
    """
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise InputError(field, str(path), f"cannot be read ({exc.strerror or exc})") from None
    return decode_text(raw, field, str(path), what, fallback)


def decode_text(raw: bytes, field: str, name: str, what: str = "text file", fallback: str | None = None) -> str:
    """Bytes of a user's text (a file, an upload named ``name``) as text, by the rules of :func:`read_text`.

    Raises:
        InputError: not text in an accepted encoding.
    """
    for bom, encoding in _BOMS:
        if raw.startswith(bom):
            try:
                return raw.decode(encoding).lstrip("\ufeff")
            except UnicodeDecodeError:
                break
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        if fallback is not None:
            return raw.decode(fallback, errors="replace")
        raise InputError(field, name, f"must be a UTF-8 {what} (byte 0x{raw[exc.start]:02X} at offset "
                                      f"{exc.start} is not UTF-8; save the file as UTF-8)") from None


#: a number written with a decimal comma (or a thousands separator): "100,5", "-1,2e-07"
COMMA_NUMBER = re.compile(r"[-+]?\d*,\d+([eE][-+]?\d+)?")
COMMA_ADVICE = "decimal commas are not accepted: write numbers with a decimal point (100.5, not 100,5)"


def parse_number(text: str, where: str) -> float:
    """One number of a CSV cell; a decimal comma, text, NaN or infinity is refused naming ``where``."""
    try:
        x = float(text)
    except ValueError:
        if COMMA_NUMBER.fullmatch(text.strip()):
            raise InputError(where, text, COMMA_ADVICE) from None
        raise InputError(where, text, "must be a number") from None
    if not math.isfinite(x):
        raise InputError(where, text, "must be a finite number (not inf or nan)")
    return x


def check_comma_separated(header: list[str], where: str, line: str, columns: str) -> None:
    """Refuse a header that is one cell holding ';' or tabs: a spreadsheet's "CSV" written in a
    decimal-comma locale, whose numbers would then be misread. ``columns`` names the expected header."""
    if len(header) == 1 and re.search(r"[;\t]", header[0]):
        sep = "';'" if ";" in header[0] else "tabs"
        raise InputError(where, line, f"columns are separated by {sep}; a CSV must separate them with commas and "
                                      f"write numbers with a decimal point (header {columns})")


def csv_rows(lines: Iterable[str], name: str) -> Iterator[list[str]]:
    """The rows of ``csv.reader(lines)``, with what the csv module cannot read as an :class:`InputError` naming
    ``name`` (the file) and the line, instead of a ``csv.Error`` that no door shows (an upload with a cell above the
    module's 131 072-character limit left the page silent).

    Raises:
        InputError: a cell longer than ``csv.field_size_limit()`` characters (a quote left open makes the rest of
            the file one cell), or another row the csv module refuses.
    """
    reader = csv.reader(lines)
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:
            limit = csv.field_size_limit()
            if "field larger than field limit" in str(exc):
                raise InputError(f"{name} line {reader.line_num}", f"a cell over {limit:,} characters",
                                 "each cell holds a number or a label (a quote left open makes the rest of the file "
                                 "one cell): is it the file meant?") from None
            raise InputError(f"{name} line {reader.line_num}", "not CSV", f"rows of comma-separated cells ({exc})"
                             ) from None
        yield row
