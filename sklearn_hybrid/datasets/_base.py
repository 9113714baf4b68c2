"""Shared helpers of the dataset loaders: data home, checked downloads, zip extraction.

The loaders never ship data. They look for files under a *data home* folder and, when a file
is missing, download it from its published source, check its digest and only then move it into
place, so that an interrupted download never leaves a partial file behind.
"""

from __future__ import annotations

import csv
import hashlib
import http.client
import os
import shutil
import socket
import tempfile
import threading
import time
import urllib.parse
import urllib.request
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = [
    "ChecksumError",
    "RemoteFile",
    "extract_zip",
    "fetch_file",
    "file_digest",
    "get_data_home",
    "read_csv_columns",
]

DATA_HOME_ENV = "SKLEARN_HYBRID_DATA"
_CHUNK = 1 << 20
_TIMEOUT_S = 60
#: Seconds to wait for a download address to answer before counting it offline.
_REACH_TIMEOUT_S = 3


class ChecksumError(OSError):
    """A data file (local or downloaded) has another digest than the published one."""


@dataclass(frozen=True)
class RemoteFile:
    """Where a data file lives inside the data home and where it is published.

    Parameters
    ----------
    filename : str
        Path of the file relative to the data home, with ``/`` separators
        (for example ``"silverbox/SNLS80mV.csv"``).
    url : str
        Download address of the exact file.
    checksum : str
        Expected hexadecimal digest of the file.
    algorithm : {"sha256", "md5"}, default="sha256"
        Hash algorithm of ``checksum``.
    mirrors : tuple of str, default=()
        Further addresses of the same bytes, tried in order after ``url``.
    """

    filename: str
    url: str
    checksum: str
    algorithm: str = "sha256"
    mirrors: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.algorithm not in ("sha256", "md5"):
            raise ValueError(f"algorithm must be 'sha256' or 'md5', got {self.algorithm!r}.")
        if Path(self.filename).is_absolute() or ".." in Path(self.filename).parts:
            raise ValueError(f"filename must be relative to the data home, got {self.filename!r}.")


def _checkout_data() -> Path | None:
    """``shared/data`` beside the source checkout the package runs from, where that folder exists.

    The project's machines keep the measured files there, outside the repository; the tests and the
    documentation build look there too. None for an installed package (no ``pyproject.toml`` beside it).
    """
    root = Path(__file__).resolve().parents[2]  # <root>/sklearn_hybrid/datasets/_base.py
    shared = root.parent / "shared" / "data"
    return shared if (root / "pyproject.toml").is_file() and shared.is_dir() else None


def get_data_home(data_home: str | os.PathLike | None = None) -> Path:
    """Return the folder where the datasets are looked for and downloaded to.

    The folder is, in this order: the ``data_home`` argument, the environment variable
    ``SKLEARN_HYBRID_DATA``, ``../shared/data`` beside the repository when the package runs from a
    source checkout and that folder exists (where the tests and the documentation build find the
    measured files), or ``~/sklearn_hybrid_data``. ``~`` is expanded. The folder is not created
    here; it is created only when a file has to be downloaded into it.

    Parameters
    ----------
    data_home : str or path-like, default=None
        Folder to use instead of the default.

    Returns
    -------
    data_home : pathlib.Path
        The data home folder.
    """
    source = "data_home"
    if data_home is None:
        source = DATA_HOME_ENV if os.environ.get(DATA_HOME_ENV) else "the default data home"
        data_home = os.environ.get(DATA_HOME_ENV) or _checkout_data() or Path("~") / "sklearn_hybrid_data"
    path = Path(data_home).expanduser()
    if path.exists() and not path.is_dir():
        raise NotADirectoryError(
            f"{source} points at {path}, which is a file; it must be a folder (the one that "
            "holds e.g. 'silverbox/SNLS80mV.csv')."
        )
    return path


def read_csv_columns(
    path: str | os.PathLike, names: list[str], max_rows: int | None = None
) -> dict[str, np.ndarray]:
    """Read named numeric columns of a comma-separated file with a one-line header.

    Columns are located by name, not position; quotes around header names, a trailing comma
    at the end of the lines (as in the Silverbox and Cascaded-tanks files) and comment lines
    starting with ``#`` before the header (as in the hare-lynx file) are tolerated.

    Parameters
    ----------
    path : str or path-like
        The CSV file.
    names : list of str
        Columns to read.
    max_rows : int, default=None
        Read at most this many data rows.

    Returns
    -------
    columns : dict of str to ndarray of shape (n_rows,)
        The columns as float64 arrays.
    """
    with open(path, newline="") as f:
        n_comments, line = 0, f.readline()
        while line.lstrip().startswith("#"):
            n_comments, line = n_comments + 1, f.readline()
        header = [h.strip() for h in next(csv.reader([line]))]
    missing = [n for n in names if n not in header]
    if missing:
        raise ValueError(f"{path} has no column(s) {missing}; its header is {header}.")
    usecols = [header.index(n) for n in names]
    data = np.loadtxt(path, delimiter=",", skiprows=n_comments + 1, usecols=usecols, ndmin=2,
                      max_rows=max_rows, dtype=np.float64)
    return {n: np.ascontiguousarray(data[:, i]) for i, n in enumerate(names)}


def file_digest(path: str | os.PathLike, algorithm: str = "sha256") -> str:
    """Return the hexadecimal digest of a file, read in chunks."""
    hasher = hashlib.new(algorithm)
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(_CHUNK), b""):
            hasher.update(block)
    return hasher.hexdigest()


def _check_digest(path: Path, remote: RemoteFile) -> None:
    found = file_digest(path, remote.algorithm)
    if found != remote.checksum.lower():
        raise ChecksumError(
            f"The file {path} does not have the published {remote.algorithm} digest.\n"
            f"  expected: {remote.checksum}\n  found:    {found}\n"
            f"It is damaged or a different version. Delete it and fetch it again from {remote.url}"
        )


def _missing_message(path: Path, remote: RemoteFile, reason: str) -> str:
    sources = "\n".join(f"  {u}" for u in (remote.url, *remote.mirrors))
    return (
        f"{reason}\nPut the file at\n  {path}\n"
        f"(or point data_home / the environment variable {DATA_HOME_ENV} at a folder holding "
        f"'{remote.filename}'). Get it from\n{sources}\n"
        f"Its {remote.algorithm} must be {remote.checksum}."
    )


def _answering(urls) -> set:
    """The addresses whose host resolves and accepts a connection within ``_REACH_TIMEOUT_S``.

    Checked in parallel daemon threads with one deadline for all: name resolution has no timeout of
    its own, and offline it can wait tens of seconds per address before failing.
    """
    answered = set()

    def probe(url):
        parts = urllib.parse.urlsplit(url)
        if parts.scheme not in ("http", "https") or not parts.hostname:
            answered.add(url)  # file:// and the like: let the download itself say
            return
        try:
            port = parts.port or (443 if parts.scheme == "https" else 80)
            socket.create_connection((parts.hostname, port), timeout=_REACH_TIMEOUT_S).close()
        except Exception:  # noqa: BLE001  whatever failed, the address did not answer; and a probe that
            return         # outlives the deadline must not raise into threading's excepthook after the call
        answered.add(url)

    threads = [threading.Thread(target=probe, args=(url,), daemon=True) for url in urls]
    for t in threads:
        t.start()
    deadline = time.monotonic() + _REACH_TIMEOUT_S
    for t in threads:
        t.join(max(0.0, deadline - time.monotonic()))
    return set(answered)


def _download(url: str, target: Path, algorithm: str) -> str:
    """Stream ``url`` into ``target``; return the digest of what was written."""
    hasher = hashlib.new(algorithm)
    with urllib.request.urlopen(url, timeout=_TIMEOUT_S) as response, open(target, "wb") as f:
        for block in iter(lambda: response.read(_CHUNK), b""):
            hasher.update(block)
            f.write(block)
    return hasher.hexdigest()


def fetch_file(
    remote: RemoteFile,
    data_home: str | os.PathLike | None = None,
    download_if_missing: bool = True,
) -> Path:
    """Return the local path of a data file, downloading and checking it if needed.

    Parameters
    ----------
    remote : RemoteFile
        The file: its place in the data home, its addresses and its digest.
    data_home : str or path-like, default=None
        Data home folder, see :func:`get_data_home`.
    download_if_missing : bool, default=True
        Whether to download the file when it is not in the data home.

    Returns
    -------
    path : pathlib.Path
        Path of the checked file.

    Raises
    ------
    ChecksumError
        If the local (or downloaded) file has another digest than the published one.
    FileNotFoundError
        If the file is missing and may not or could not be downloaded; the message names the
        full path to put it at and where to get it.
    """
    path = get_data_home(data_home) / remote.filename
    if path.is_file():
        _check_digest(path, remote)
        return path
    if path.exists():  # a folder (or another non-file) where the file should be: no download can replace it
        raise IsADirectoryError(
            _missing_message(path, remote, f"{path} is a folder (or another thing that is not a file) where the "
                                           f"data file {remote.filename} should be: remove or rename it.")
        )
    if not download_if_missing:
        raise FileNotFoundError(
            _missing_message(path, remote, f"{remote.filename} is not in the data home and "
                                           "download_if_missing=False.")
        )
    created = [p for p in (path.parent, *path.parent.parents) if not p.exists()]
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        return _download_checked(remote, path)
    except BaseException:
        for folder in created:  # innermost first: leave no empty folders behind
            try:
                folder.rmdir()
            except OSError:
                break
        raise


def _download_checked(remote: RemoteFile, path: Path) -> Path:
    """Try the addresses of ``remote`` in order; move the first verified download to ``path``."""
    errors, mismatches = [], []
    urls = (remote.url, *remote.mirrors)
    answering = _answering(urls)
    if not answering:  # offline: say so at once rather than after every address's timeouts
        raise FileNotFoundError(_missing_message(
            path, remote, f"Could not download {remote.filename}: none of its {len(urls)} address(es) answered "
                          f"within {_REACH_TIMEOUT_S} s (no network?)."))
    for url in urls:
        if url not in answering:
            errors.append(f"  {url}: no answer within {_REACH_TIMEOUT_S} s")
            continue
        # A temporary file in the same folder, renamed only once verified: no partial files.
        fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
        os.close(fd)
        tmp = Path(tmp_name)
        try:
            found = _download(url, tmp, remote.algorithm)
        except (OSError, ValueError, http.client.HTTPException) as exc:  # URLError is an OSError
            tmp.unlink(missing_ok=True)
            errors.append(f"  {url}: {exc}")
            continue
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        if found != remote.checksum.lower():
            tmp.unlink(missing_ok=True)
            mismatches.append(f"  {url}: {found}")
            continue
        os.replace(tmp, path)
        return path
    if mismatches:
        raise ChecksumError(
            f"The download of {remote.filename} has another {remote.algorithm} digest than the "
            f"published one.\n  expected: {remote.checksum}\n  found:\n" + "\n".join(mismatches)
            + f"\nNothing was written to {path}."
        )
    reason = "Could not download " + remote.filename + ":\n" + "\n".join(errors)
    raise FileNotFoundError(_missing_message(path, remote, reason))


def extract_zip(
    zip_path: str | os.PathLike, destination: str | os.PathLike, top_folder: str
) -> Path:
    """Extract the members of a zip archive that lie under ``top_folder``.

    Members outside ``top_folder`` (for example ``__MACOSX/`` folders) are skipped. The members
    are extracted into a temporary folder beside the target, which is renamed into place only
    when complete, so an interrupted extraction leaves nothing behind.

    Parameters
    ----------
    zip_path : str or path-like
        The archive.
    destination : str or path-like
        Folder that receives ``top_folder``.
    top_folder : str
        Name of the top-level folder to extract.

    Returns
    -------
    folder : pathlib.Path
        ``destination / top_folder``.

    Raises
    ------
    ValueError
        If a member has an absolute path or ``..`` ("zip slip"), or no member lies under
        ``top_folder``.
    FileExistsError
        If ``destination / top_folder`` already exists.
    """
    destination = Path(destination)
    target = destination / top_folder
    if target.exists():
        raise FileExistsError(f"{target} already exists; remove it to extract {zip_path} again.")
    with zipfile.ZipFile(zip_path) as archive:
        members = []
        for info in archive.infolist():
            parts = Path(info.filename).parts
            if info.filename.startswith(("/", "\\")) or ".." in parts:
                raise ValueError(f"Unsafe member {info.filename!r} in {zip_path}.")
            if parts and parts[0] == top_folder:
                members.append(info)
        if not members:
            raise ValueError(f"{zip_path} holds no folder '{top_folder}/'.")
        destination.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{top_folder}.", dir=destination))
        try:
            archive.extractall(staging, members=members)
            os.replace(staging / top_folder, target)
        finally:
            shutil.rmtree(staging, ignore_errors=True)
    return target
