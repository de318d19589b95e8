"""Collecting an agent's ``/output`` safely (docs/architecture.md, 'The sandbox').

Only top-level regular files are read; nothing is followed: a symbolic link, FIFO, device,
socket or folder is refused with a reason, and so is an oversized file or a name that is not
a plain file name. Files are opened relative to the folder with O_NOFOLLOW | O_NONBLOCK and
checked again after opening, so a swap between the look and the read is caught too. Names
starting with a dot are temporary files (write, then rename) and are skipped.
"""

from __future__ import annotations

import os
import re
import shutil
import stat
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

from schemas import FileCheck

_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,127}$")
MAX_FILES = 64


@dataclass
class Collected:
    files: dict[str, bytes] = field(default_factory=dict)
    refused: list[FileCheck] = field(default_factory=list)


def _kind(mode: int) -> str | None:
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISLNK(mode):
        return "a symbolic link (never followed)"
    if stat.S_ISFIFO(mode):
        return "a FIFO (only regular files are collected)"
    if stat.S_ISDIR(mode):
        return "a folder (only top-level regular files are collected)"
    if stat.S_ISSOCK(mode):
        return "a socket (only regular files are collected)"
    return "a device or special file (only regular files are collected)"


def collect(folder: Path, *, max_file_bytes: int, max_total_bytes: int) -> Collected:
    """Reads the regular files of ``folder`` within the caps; refuses everything else."""
    out = Collected()
    try:
        dfd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW)
    except OSError as e:
        out.refused.append(FileCheck(name=str(folder), ok=False, reason=f"cannot open: {e}"))
        return out
    total = 0
    try:
        names = sorted(os.listdir(dfd))
        for name in names:
            if name.startswith("."):
                continue
            if len(out.files) + len(out.refused) >= MAX_FILES:
                out.refused.append(
                    FileCheck(name=name, ok=False, reason=f"more than {MAX_FILES} files")
                )
                break
            if not _NAME.match(name):
                out.refused.append(FileCheck(name=repr(name)[:80], ok=False,
                                             reason="not a plain file name"))
                continue
            try:
                st = os.stat(name, dir_fd=dfd, follow_symlinks=False)
            except OSError as e:
                out.refused.append(FileCheck(name=name, ok=False, reason=f"cannot stat: {e}"))
                continue
            why = _kind(st.st_mode)
            if why is None and st.st_size > max_file_bytes:
                why = f"{st.st_size} bytes exceeds the cap of {max_file_bytes} bytes"
            if why is None and total + st.st_size > max_total_bytes:
                why = f"the files together exceed the cap of {max_total_bytes} bytes"
            if why is not None:
                out.refused.append(FileCheck(name=name, ok=False, size=st.st_size, reason=why))
                continue
            try:
                fd = os.open(name, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK, dir_fd=dfd)
            except OSError as e:
                out.refused.append(FileCheck(name=name, ok=False, reason=f"cannot open: {e}"))
                continue
            try:
                st2 = os.fstat(fd)
                why = _kind(st2.st_mode)
                if why is not None:
                    out.refused.append(FileCheck(name=name, ok=False, reason=why))
                    continue
                data = os.read(fd, max_file_bytes + 1)
                chunks = [data]
                while data and sum(map(len, chunks)) <= max_file_bytes:
                    data = os.read(fd, max_file_bytes + 1)
                    chunks.append(data)
                blob = b"".join(chunks)
                if len(blob) > max_file_bytes:
                    out.refused.append(FileCheck(
                        name=name, ok=False, size=len(blob),
                        reason=f"grew past the cap of {max_file_bytes} bytes while read"))
                    continue
                out.files[name] = blob
                total += len(blob)
            finally:
                os.close(fd)
    finally:
        os.close(dfd)
    return out


def mount_output(folder: Path, size_mb: int, uid: int) -> bool:
    """Makes ``folder`` a size-capped tmpfs owned by ``uid`` (needs root). False if it can't.

    Without the mount the folder is plain and its size is only capped at collection.
    """
    folder.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0 or shutil.which("mount") is None:
        folder.chmod(0o777)
        return False
    r = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size_mb}m,mode=0700,uid={uid},gid={uid},"
         "nosuid,nodev,noexec", "eagc-output", str(folder)],
        capture_output=True,
    )
    if r.returncode != 0:
        folder.chmod(0o777)
        return False
    return True


def unmount_output(folder: Path) -> None:
    subprocess.run(["umount", "-l", str(folder)], capture_output=True)
