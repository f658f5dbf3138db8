"""The campaign folder: one writer at a time, and which campaign it holds.

* :class:`FolderLock`: an advisory lock (``fcntl.flock``) on ``<folder>/.campaign.lock``, held
  while a campaign runs into the folder. The kernel releases it when its process ends, however
  it ends (Ctrl-C, ``kill -9``, power loss); the file holds the holder's pid, host, start time
  and campaign, so a second campaign is told who has the folder. A lock file that exists but is
  not locked was left by a process that was killed: it is taken over (:meth:`FolderLock.acquire`
  returns the old holder, for a warning). A campaign that ends releases the lock by removing the
  file while it holds it; whoever locked that removed file then tries the new one.
* :func:`folder_campaign`: the identity (name, scenarios) of the campaign whose
  ``campaign.toml`` the folder holds, to refuse resuming another campaign's folder.
* :func:`write_text_atomic`: a text file written as results.parquet is (a temporary file in the
  same folder, then a rename), so a reader never sees half of it.

On a platform without ``fcntl`` (Windows) the lock does nothing.
"""

from __future__ import annotations

import datetime as _dt
import errno
import json
import os
import re
import socket
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

from ..errors import FfsmError
from ..sim.files import replaced_file

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: no lock
    fcntl = None  # type: ignore[assignment]

__all__ = [
    "CAMPAIGN_FILE",
    "LOCK_FILE",
    "CampaignFolderError",
    "CampaignIdentity",
    "FolderInUseError",
    "FolderLock",
    "Holder",
    "campaign_file_text",
    "folder_campaign",
    "write_text_atomic",
]

#: The lock file in a campaign folder (present while a campaign runs, or left by a killed one).
LOCK_FILE = ".campaign.lock"
#: The campaign as run, in its folder.
CAMPAIGN_FILE = "campaign.toml"
# First line of campaign.toml: the campaign's name (its file's name when the file gives none).
_HEADER = "# campaign {name} from {source}, as run by python -m ffsm_pin.sweep\n"
_HEADER_RE = re.compile(r'# campaign ("(?:[^"\\]|\\.)*") from ')
# Temporary files of an atomic write (this module's and ResultsTable.write's).
_TEMP_GLOBS = (".results.parquet.*.tmp", f".{CAMPAIGN_FILE}.*.tmp")


class FolderInUseError(FfsmError, RuntimeError):
    """Another campaign holds the campaign folder's lock."""


class CampaignFolderError(FfsmError, ValueError):
    """A campaign folder that holds another campaign, or a campaign.toml that is none."""


@dataclass(frozen=True)
class Holder:
    """Who holds (or held) a campaign folder's lock.

    Attributes
    ----------
    pid : int or None
        The process id (None: unknown).
    host : str
        The host name.
    since : str
        Local time the campaign took the lock, YYYY-mm-dd HH:MM:SS.
    campaign : str
        The campaign's name.
    """

    pid: int | None
    host: str
    since: str  # local time the campaign took the lock, ``YYYY-mm-dd HH:MM:SS``
    campaign: str

    def text(self) -> str:
        """``campaign 'name' (pid N on host H since T)``, as the messages show it."""
        who = f"campaign {self.campaign!r}" if self.campaign else "another campaign"
        return f"{who} (pid {self.pid} on host {self.host} since {self.since})"

    @classmethod
    def parse(cls, text: str) -> Holder | None:
        """The holder a lock file's text names (None: empty or not a lock file's text)."""
        try:
            d = json.loads(text)
            pid = d.get("pid")
            return cls(
                pid=pid if isinstance(pid, int) else None,
                host=str(d.get("host", "?")),
                since=str(d.get("since", "?")),
                campaign=str(d.get("campaign", "")),
            )
        except (ValueError, AttributeError):
            return None


class FolderLock:
    """The lock of a campaign folder (module docstring); a context manager.

    Parameters
    ----------
    folder : Path
        The campaign folder (created if missing).
    campaign : str
        The name of the campaign taking the lock (written into the lock file).
    """

    def __init__(self, folder: Path, campaign: str = ""):
        self.folder = Path(folder)
        self.path = self.folder / LOCK_FILE
        self.campaign = campaign
        self.stale: Holder | None = None  # the killed holder whose lock was taken over
        self.unsupported: str | None = None  # why the folder could not be locked, if so
        self._fd: int | None = None

    def acquire(self) -> FolderLock:
        """Take the lock; remove temporary files that a killed writer left.

        Returns
        -------
        FolderLock
            ``self``; :attr:`stale` is the holder of a lock file left by a killed process
            (taken over), :attr:`unsupported` says why the file system cannot lock (the
            campaign then runs unlocked).

        Raises
        ------
        FolderInUseError
            Another process holds the lock (the message names it and what to do).
        OSError
            The folder or the lock file cannot be created.
        """
        self.folder.mkdir(parents=True, exist_ok=True)
        if fcntl is None:  # pragma: no cover - Windows
            return self
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    os.close(fd)  # ENOLCK and the like: a file system without locks
                    self.unsupported = f"{self.path}: {exc.strerror or exc}"
                    return self
                holder = _read_holder(fd)
                os.close(fd)
                who = holder.text() if holder else "another campaign"
                raise FolderInUseError(
                    f"campaign folder {str(self.folder)!r} is in use by {who}; wait for it or "
                    "choose another --out"
                ) from None
            if _same_file(fd, self.path):
                break
            os.close(fd)  # the holder removed that file on release: lock the new one
        self._fd = fd
        self.stale = Holder.parse(_read_all(fd))
        me = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "since": _dt.datetime.now().strftime("%Y-%m-%d %H:%M:%S"),
            "campaign": self.campaign,
        }
        os.ftruncate(fd, 0)
        os.pwrite(fd, (json.dumps(me) + "\n").encode(), 0)
        for pattern in _TEMP_GLOBS:  # nobody else writes here now: a killed writer's leftovers
            for tmp in self.folder.glob(pattern):
                tmp.unlink(missing_ok=True)
        return self

    def release(self) -> None:
        """Remove the lock file and release the lock (nothing if not held)."""
        fd, self._fd = self._fd, None
        if fd is None:
            return
        try:
            self.path.unlink(missing_ok=True)
        finally:
            os.close(fd)

    @property
    def held(self) -> bool:
        """Whether this object holds the lock."""
        return self._fd is not None

    def __enter__(self) -> FolderLock:
        return self.acquire()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.release()


def _read_all(fd: int) -> str:
    chunks, offset = [], 0
    while chunk := os.pread(fd, 4096, offset):
        chunks.append(chunk)
        offset += len(chunk)
    return b"".join(chunks).decode("utf-8", "replace")


def _read_holder(fd: int, wait_s: float = 1.0) -> Holder | None:
    """The holder named in the lock file (it writes its name just after locking: wait a bit)."""
    deadline = time.monotonic() + wait_s
    while True:
        holder = Holder.parse(_read_all(fd))
        if holder is not None or time.monotonic() > deadline:
            return holder
        time.sleep(0.05)


def _same_file(fd: int, path: Path) -> bool:
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return False
    own = os.fstat(fd)
    return (st.st_dev, st.st_ino) == (own.st_dev, own.st_ino)


# ------------------------------------------------------------------------------ campaign.toml
@dataclass(frozen=True)
class CampaignIdentity:
    """What makes two campaigns the same one: the name and the scenarios (in any order).

    Attributes
    ----------
    name : str or None
        The campaign's name; None: a campaign.toml that names no campaign (written by an old
        version).
    scenarios : tuple of str
        The scenarios, as written in the file.
    """

    name: str | None  # None: a campaign.toml that names no campaign (written by an old version)
    scenarios: tuple[str, ...]  # as written in the file

    def same_as(self, other: CampaignIdentity) -> bool:
        """Same scenarios, and the same name where both are known."""
        names = self.name is None or other.name is None or self.name == other.name
        return names and sorted(self.scenarios) == sorted(other.scenarios)

    def text(self) -> str:
        """``'name' (scenario case1)``, as the messages show it."""
        name = repr(self.name) if self.name is not None else "(unnamed)"
        word = "scenario" if len(self.scenarios) == 1 else "scenarios"
        return f"{name} ({word} {', '.join(self.scenarios)})"


def campaign_file_text(name: str, source: str, text: str) -> str:
    """The text of a folder's ``campaign.toml``: a comment naming the campaign and its file
    (the name a file without ``name`` gets is its file name), then the campaign file (without
    such a comment of its own: a folder's campaign.toml run again).

    Parameters
    ----------
    name : str
        The campaign's name.
    source : str
        Its file.
    text : str
        The campaign file's text.

    Returns
    -------
    str
        The folder's ``campaign.toml``.
    """
    while _HEADER_RE.match(text):
        text = text.partition("\n")[2]
    return _HEADER.format(name=json.dumps(name), source=source) + text


def folder_campaign(folder: Path) -> CampaignIdentity | None:
    """The campaign of ``folder/campaign.toml`` (None when there is none).

    Raises
    ------
    CampaignFolderError
        The file is not a campaign file (not TOML, or without ``[campaign] scenario``).
    """
    path = Path(folder) / CAMPAIGN_FILE
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError) as exc:
        raise CampaignFolderError(f"cannot read {str(path)!r}: {exc}") from None
    try:
        table: Any = tomllib.loads(text).get("campaign")
        scenario = table["scenario"]
    except (tomllib.TOMLDecodeError, TypeError, KeyError, AttributeError) as exc:
        what = (
            f"invalid TOML: {exc}"
            if isinstance(exc, tomllib.TOMLDecodeError)
            else ("no [campaign] scenario")
        )
        raise CampaignFolderError(f"{str(path)!r} is not a campaign file ({what})") from None
    scenarios = tuple(str(s) for s in scenario) if isinstance(scenario, list) else (str(scenario),)
    name = table.get("name")
    if not isinstance(name, str) or not name:
        m = _HEADER_RE.match(text)
        name = json.loads(m.group(1)) if m else None
    return CampaignIdentity(name, scenarios)


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder and a rename: a
    reader sees the old file or the new one, never a part.

    Parameters
    ----------
    path : Path
        The file.
    text : str
        Its new text.
    """
    with replaced_file(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
