"""A scenario file's text: a regular file of at most :data:`MAX_FILE_BYTES`, decided from
``os.stat`` before it is opened (a FIFO, device or socket is never opened), decoded as UTF-8 (a
UTF-8 byte order mark is skipped; UTF-16/32 are named and refused), and holding only the
characters YAML allows, less the three that YAML 1.1 alone counts as line breaks (U+0085,
U+2028, U+2029), so that every line:col is the one an editor shows. Every refusal is a :class:`stackdsl.lang.errors.ScenarioError` at the file,
and at line:col where there is one.

Source: stackdsl's own.
"""

from __future__ import annotations

import os
import re
import stat
import unicodedata
from pathlib import Path

import yaml

from ..util.files import file_kind
from .errors import ScenarioError, one_line

MAX_FILE_BYTES = 1 << 20  # a scenario file is at most 1 MiB
# Line breaks as an editor counts them (and as YAML does in a file without the characters below).
_LINE_BREAK = re.compile(r"\r\n|[\r\n]")
# Characters YAML 1.1 (PyYAML) takes for line breaks and an editor, YAML 1.2 and JSON do not: refused
# where they are written, each with the escape that writes it in a double-quoted string.
_YAML11_BREAKS = {
    "\x85": ("U+0085 NEXT LINE (NEL)", "\\N"),
    "\u2028": ("U+2028 LINE SEPARATOR", "\\L"),
    "\u2029": ("U+2029 PARAGRAPH SEPARATOR", "\\P"),
}
_YAML11_BREAK = re.compile("[\x85\u2028\u2029]")
_C0_NAMES = (
    "NULL START_OF_HEADING START_OF_TEXT END_OF_TEXT END_OF_TRANSMISSION ENQUIRY ACKNOWLEDGE BELL "
    "BACKSPACE CHARACTER_TABULATION LINE_FEED LINE_TABULATION FORM_FEED CARRIAGE_RETURN SHIFT_OUT "
    "SHIFT_IN DATA_LINK_ESCAPE DEVICE_CONTROL_ONE DEVICE_CONTROL_TWO DEVICE_CONTROL_THREE "
    "DEVICE_CONTROL_FOUR NEGATIVE_ACKNOWLEDGE SYNCHRONOUS_IDLE END_OF_TRANSMISSION_BLOCK CANCEL "
    "END_OF_MEDIUM SUBSTITUTE ESCAPE INFORMATION_SEPARATOR_FOUR INFORMATION_SEPARATOR_THREE "
    "INFORMATION_SEPARATOR_TWO INFORMATION_SEPARATOR_ONE"
).split()
_BOMS = (  # longest first: the UTF-32 LE mark starts with the UTF-16 LE one
    (b"\xff\xfe\x00\x00", "UTF-32"),
    (b"\x00\x00\xfe\xff", "UTF-32"),
    (b"\xff\xfe", "UTF-16"),
    (b"\xfe\xff", "UTF-16"),
)


def read_text(path: Path, shown: str | None = None) -> str:
    """The UTF-8 text of the regular file ``path`` (checked with :func:`file_problem` first).
    Raises ScenarioError, naming the file ``shown`` (default: ``path``), when it cannot be read,
    is not a regular file once open, is larger than :data:`MAX_FILE_BYTES`, or is not UTF-8 text."""
    name = str(path) if shown is None else shown
    return _decode(_read_bytes(path, name), name)


def file_problem(path: Path) -> str | None:
    """Why ``path`` cannot be read as a scenario file, from ``os.stat`` alone (nothing is
    opened); None for a regular file of at most :data:`MAX_FILE_BYTES`. A trajectory file
    (``.npz``) too large to read is named as one here; a smaller one, or a zip archive of
    another name, once read (:func:`read_text`).

    >>> file_problem(Path("/dev/null"))
    'not a regular file: a character device'
    """
    try:
        info = path.stat()
    except FileNotFoundError:
        return "a broken symbolic link" if path.is_symlink() else "no such file or folder" + _relative_to(path)
    except OSError as exc:
        return f"cannot read the file: {exc.strerror or exc}"
    if not stat.S_ISREG(info.st_mode):
        return f"not a regular file: {file_kind(info.st_mode)}"
    if info.st_size > MAX_FILE_BYTES:
        if path.suffix.lower() == ".npz":
            return not_a_scenario(path)
        return f"the file is larger than {MAX_FILE_BYTES} bytes ({info.st_size} bytes)"
    return None


def _relative_to(path: Path) -> str:
    """For a relative ``path``, the folder it was looked for in, as a note to a message: a new
    user who ran a command from another folder saw only the name they gave. Empty for an
    absolute path, or when the working folder is gone."""
    if path.is_absolute():
        return ""
    try:
        return f" (looked for in {one_line(os.getcwd())})"
    except OSError:
        return ""


#: The first bytes of a zip archive (a trajectory file, ``.npz``, is one).
ZIP_MAGIC = b"PK\x03\x04"


def not_a_scenario(path: Path) -> str:
    """Why the zip archive ``path`` is not a scenario: a trajectory file (``.npz``) and the
    commands that read one."""
    readers = "stackdsl render, animate, graph, replay, view and export read it"
    if path.suffix.lower() == ".npz":
        return f"this is a trajectory file (.npz), not a scenario: {readers}"
    return f"this is a zip archive, not a scenario (YAML text); if it is a trajectory file, {readers}"


def _read_bytes(path: Path, file: str) -> bytes:
    """At most ``MAX_FILE_BYTES + 1`` bytes of the regular file ``path``.

    Opened non-blocking, and checked again once open, so that a file swapped for a FIFO or
    device after :func:`file_problem` neither blocks nor streams without end.
    """
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise ScenarioError(f"cannot read the file: {exc.strerror or exc}", file=file) from None
    with os.fdopen(fd, "rb") as handle:
        mode = os.fstat(handle.fileno()).st_mode
        if not stat.S_ISREG(mode):
            raise ScenarioError(f"not a regular file: {file_kind(mode)}", file=file)
        try:
            raw = handle.read(MAX_FILE_BYTES + 1)
        except OSError as exc:
            raise ScenarioError(f"cannot read the file: {exc.strerror or exc}", file=file) from None
    if len(raw) > MAX_FILE_BYTES:
        raise ScenarioError(f"the file is larger than {MAX_FILE_BYTES} bytes", file=file)
    return raw


def _decode(raw: bytes, file: str) -> str:
    """UTF-8 text of ``raw`` (a UTF-8 byte order mark is dropped)."""
    if raw.startswith(ZIP_MAGIC):
        raise ScenarioError(not_a_scenario(Path(file)), file=file)
    for bom, encoding in _BOMS:
        if raw.startswith(bom):
            raise ScenarioError(
                f"the file is {encoding} text (it starts with a {encoding} byte order mark); save it as UTF-8", file=file
            )
    try:
        return raw.decode("utf-8").removeprefix("\ufeff")
    except UnicodeDecodeError as exc:
        before = raw[: exc.start].decode("utf-8").removeprefix("\ufeff")
        line, column, text = _position(before + "\ufffd", len(before))
        raise ScenarioError(
            f"the file is not UTF-8 text: byte 0x{raw[exc.start]:02x} ({exc.reason})",
            file=file,
            line=line,
            column=column,
            source_line=text,
        ) from None


def _position(text: str, index: int) -> tuple[int, int, str]:
    """1-based line and column of ``text[index]``, counting lines as an editor does (CR LF, CR or
    LF end one), and its line."""
    line, start = 1, 0
    for brk in _LINE_BREAK.finditer(text, 0, index):
        line, start = line + 1, brk.end()
    found = _LINE_BREAK.search(text, index)
    return line, index - start + 1, text[start : found.start() if found else len(text)]


def character_name(ch: str) -> str:
    """``"\\x0c"`` -> ``"U+000C FORM FEED"``."""
    code = ord(ch)
    if code < len(_C0_NAMES):
        name = _C0_NAMES[code].replace("_", " ")
    elif code == 0x7F:
        name = "DELETE"
    elif 0x80 <= code <= 0x9F:
        name = "(a C1 control character)"
    elif 0xD800 <= code <= 0xDFFF:
        name = "(a lone surrogate)"
    elif code in (0xFFFE, 0xFFFF):
        name = "(a noncharacter)"
    else:
        name = unicodedata.name(ch, "")
    return f"U+{code:04X} {name}".rstrip()


def check_characters(text: str, file: str) -> None:
    """Refuse the first character YAML does not allow (PyYAML's own test), or that YAML 1.1 reads
    as a line break and an editor does not (U+0085, U+2028, U+2029: PyYAML would count lines
    past it that the editor does not show, and end a comment there), at its line:col as an
    editor shows it."""
    bad = yaml.reader.Reader.NON_PRINTABLE.search(text)
    brk = _YAML11_BREAK.search(text)
    found = [i for i in (bad.start() if bad else -1, text.find("\ufeff"), brk.start() if brk else -1) if i >= 0]
    if not found:  # (the caller drops a leading BOM)
        return
    at = min(found)
    line, column, shown = _position(text, at)
    if text[at] == "\ufeff":
        message = "U+FEFF (a byte order mark) is allowed only at the start of the file"
    elif text[at] in _YAML11_BREAKS:
        name, escape = _YAML11_BREAKS[text[at]]
        message = (
            f"{name} is not allowed: YAML 1.1, which stackdsl reads, takes it for a line break where an editor "
            f"shows none; remove it, or write it as {escape} in a double-quoted string"
        )
    else:
        message = f"{character_name(text[at])} is not allowed in YAML"
    if text[at] == "\x00":
        message += " (is the file UTF-16, or not text at all?)"
    raise ScenarioError(message, file=file, line=line, column=column, source_line=shown)
