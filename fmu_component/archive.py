"""An FMU archive checked before anything of it is used: its members (no path out of the folder it unpacks to, no
link, a bounded size) and its model description (bounded, without a DTD, hence without entities to expand), then
unpacked into a folder of its own."""

from __future__ import annotations

import os
import re
import shutil
import stat
import tempfile
import zipfile
from pathlib import Path, PurePosixPath

MAX_UNPACKED_BYTES = 4 << 30          # an FMU's members, uncompressed
MAX_DESCRIPTION_BYTES = 64 << 20      # modelDescription.xml
MAX_MEMBERS = 100_000
UNPACK_ROOT = "cosim-fmu"             # under the system's temporary folder: one folder per FMU instance, named by pid
FMI_VERSIONS = ("2.0", "3.0")


class FmuArchiveError(ValueError):
    """What is wrong with an FMU file, in one line."""


def check_archive(path: Path) -> None:
    """Refuse an FMU whose members would leave the folder it unpacks to (an absolute path, '..', a drive or a
    backslash), are links, are too many, or unpack to more than ``MAX_UNPACKED_BYTES``."""
    if not path.is_file():
        raise FmuArchiveError("does not exist")
    if not zipfile.is_zipfile(path):
        raise FmuArchiveError("is not a zip archive (corrupt or truncated)")
    with zipfile.ZipFile(path) as archive:
        members = archive.infolist()
        if len(members) > MAX_MEMBERS:
            raise FmuArchiveError(f"has {len(members):,} members (at most {MAX_MEMBERS:,})")
        total = 0
        for member in members:
            name = member.filename
            parts = PurePosixPath(name).parts
            if name.startswith("/") or "\\" in name or ".." in parts or (parts and ":" in parts[0]):
                raise FmuArchiveError(f"has a member '{name}' whose path leaves the folder it unpacks to")
            if stat.S_ISLNK(member.external_attr >> 16):
                raise FmuArchiveError(f"has a member '{name}' that is a link")
            total += member.file_size
        if total > MAX_UNPACKED_BYTES:
            raise FmuArchiveError(f"unpacks to {total:,} bytes (at most {MAX_UNPACKED_BYTES:,})")
        try:
            description = archive.getinfo("modelDescription.xml")
        except KeyError:
            raise FmuArchiveError("has no modelDescription.xml") from None
        if description.file_size > MAX_DESCRIPTION_BYTES:
            raise FmuArchiveError(f"has a modelDescription.xml of {description.file_size:,} bytes "
                                  f"(at most {MAX_DESCRIPTION_BYTES:,})")
        text = archive.read(description)
    head = text[:4096].lower()
    if b"<!doctype" in head or b"<!entity" in text.lower():
        raise FmuArchiveError("has a modelDescription.xml with a DTD or entities (an FMI model description has none)")
    version = re.search(rb"""fmiVersion\s*=\s*["']([^"']*)["']""", text)
    if version is None or version[1].decode(errors="replace") not in FMI_VERSIONS:
        found = version[1].decode(errors="replace") if version else "without an fmiVersion"
        raise FmuArchiveError(f"is FMI {found}; FMI {' or '.join(FMI_VERSIONS)} is needed")


def one_line(exc: BaseException, limit: int = 300) -> str:
    """An exception's whole message on one line (fmpy puts the reason on the lines after its first), its type if
    the message says little."""
    text = " ".join(line.strip() for line in str(exc).splitlines() if line.strip())
    if len(text.strip(": ")) < 8:        # "77", ": 77": what it is, with the type
        text = f"{type(exc).__name__}: {text.strip(': ')}".rstrip(": ")
    return text if len(text) <= limit else text[:limit - 3] + "..."


def read_description(path: Path):
    """The FMU's model description (fmpy's), its FMI version checked: 2.0 or 3.0, with Co-Simulation."""
    from fmpy import read_model_description
    try:
        md = read_model_description(str(path))
    except Exception as exc:  # fmpy raises several types for a bad model description
        raise FmuArchiveError(f"has no valid modelDescription.xml: {one_line(exc)}") from None
    if md.fmiVersion not in FMI_VERSIONS:
        raise FmuArchiveError(f"is FMI {md.fmiVersion}; FMI {' or '.join(FMI_VERSIONS)} is needed")
    if md.coSimulation is None:
        raise FmuArchiveError(f"is FMI {md.fmiVersion} without Co-Simulation; a Co-Simulation FMU is needed")
    identifier = md.coSimulation.modelIdentifier
    if not isinstance(identifier, str) or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", identifier):
        raise FmuArchiveError(f"has the modelIdentifier {str(identifier)[:60]!r}, not a C name: its binary would be "
                              "looked for outside binaries/")
    return md


def unpack_directory() -> Path:
    """A new folder to unpack an FMU into, named after this process; folders of processes that died
    without removing theirs (killed by SIGKILL) are removed first."""
    root = Path(tempfile.gettempdir()) / UNPACK_ROOT
    root.mkdir(exist_ok=True)
    for folder in root.iterdir():
        pid = folder.name.partition("-")[0]
        if pid.isdigit() and not Path(f"/proc/{pid}").exists():
            shutil.rmtree(folder, ignore_errors=True)
    return Path(tempfile.mkdtemp(prefix=f"{os.getpid()}-", dir=root))


def unpack(path: Path, folder: Path) -> None:
    """The checked archive's members into ``folder``."""
    with zipfile.ZipFile(path) as archive:
        archive.extractall(folder)
