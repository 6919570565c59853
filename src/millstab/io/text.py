"""Reading users' text files: byte-order marks and encodings handled in one place.

Windows editors save text with a byte-order mark: Notepad's "UTF-8" writes EF BB BF before the
first character (which TOML and CSV parsers then see as part of the first key or cell), and its
"Unicode" writes UTF-16 with FF FE. Both are accepted here; anything else must be UTF-8, except
where a caller names a fallback (CutPro writes Windows-1252 text, e.g. a "µm/N" label as byte B5).
"""

from __future__ import annotations

import codecs
from pathlib import Path

from millstab.errors import InputError

_BOMS = ((codecs.BOM_UTF8, "utf-8-sig"), (codecs.BOM_UTF16_LE, "utf-16"), (codecs.BOM_UTF16_BE, "utf-16"))


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
        raise InputError(field, str(path), f"must be a UTF-8 {what} (byte 0x{raw[exc.start]:02X} at offset "
                                           f"{exc.start} is not UTF-8; save the file as UTF-8)") from None
