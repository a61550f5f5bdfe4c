"""Files stackdsl writes for a person: written whole or not at all.

Every output (a picture, a clip, a trajectory, a table, a report) is written to a hidden
temporary name in its own folder and renamed over the final name when it is complete, so a
run that is killed, runs out of disk or fails half-way leaves nothing under the final name
(a rename within a folder is atomic).

>>> import tempfile
>>> folder = Path(tempfile.mkdtemp())
>>> with written(folder / "a.txt") as part:
...     _ = part.write_text("done")
>>> sorted(p.name for p in folder.iterdir()), (folder / "a.txt").read_text()
(['a.txt'], 'done')

Source: stackdsl's own.
"""

from __future__ import annotations

import errno
import os
import secrets
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


def file_kind(mode: int) -> str:
    """A file that is not regular, in words."""
    kinds = (
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISSOCK, "a socket"),
    )
    return next((name for test, name in kinds if test(mode)), "a special file")


class NotRegularFile(FileExistsError):
    """An output path taken by something that is not a regular file (a FIFO, a device)."""


@contextmanager
def written(path: str | os.PathLike[str]) -> Iterator[Path]:
    """A temporary path beside ``path`` (same folder, same suffix, a hidden name) to write to;
    renamed to ``path`` when the block ends, removed when it raises. A ``path`` that exists and
    is not a regular file (a folder, a device such as /dev/full, a FIFO, which would block the
    writer until something reads it) is refused before anything is written. An OSError names
    ``path``, not the temporary name.

    Raises:
        OSError: the folder takes no new file, or the rename fails; :class:`NotRegularFile`:
            ``path`` is there and is not a regular file.
    """
    final = Path(path)
    if final.exists() and not final.is_file():  # a folder, a device, a FIFO: never written to or replaced
        mode = final.stat().st_mode
        if stat.S_ISDIR(mode):
            raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(final))
        raise NotRegularFile(errno.EEXIST, f"not a regular file: {file_kind(mode)}", str(final))
    # a name no one else picks; the writer creates it, so it gets the usual permissions (umask)
    part = final.with_name(f".{final.stem[:40]}.{secrets.token_hex(6)}.part{final.suffix}")
    try:
        yield part
        os.replace(part, final)
    except OSError as exc:
        part.unlink(missing_ok=True)
        # the user gave the final name: say that one (also when a failed write or close named none)
        if exc.filename in (str(part), part) or (exc.filename is None and exc.errno is not None):
            exc.filename = str(final)
        raise
    except BaseException:
        part.unlink(missing_ok=True)
        raise
