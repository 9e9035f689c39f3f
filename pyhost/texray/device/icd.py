"""Registers Intel's OpenCL CPU runtime with the OpenCL ICD loader, so that after
``pip install 'texray[intel]'`` texray finds it without any environment set; and NVIDIA's
OpenCL driver where a container or cluster mounts the driver without its ICD file.

NVIDIA's driver ships ``libnvidia-opencl.so.1``, and its packages an
``/etc/OpenCL/vendors/nvidia.icd`` naming it; a container runtime that mounts the
driver's libraries (``/usr/local/nvidia/lib64`` on the machine this project was lent,
an H200, 2026-12-04) often brings the library without the ICD file, and then OpenCL
sees no GPU (there: only PoCL). :func:`find_nvidia` looks for the library in
``LD_LIBRARY_PATH`` and the usual driver directories (:data:`NVIDIA_DIRS`); where the
loader's directory names no ``libnvidia-opencl`` the vendor directory below lists it too.
A library that cannot load (no GPU, a driver without its kernel module) costs nothing:
the loader skips an ICD it cannot open.

The wheel ``intel-opencl-rt`` installs ``libintelocl.so`` (into the environment's
``lib/``, beside ``libimf.so``, ``libsvml.so`` and TBB, which it finds through its
``$ORIGIN`` run path: no ``LD_LIBRARY_PATH`` is needed), but no usable ICD file: the
``etc/OpenCL/vendors/intel-cpu.icd`` it ships names a conda build path
(``/opt/anaconda1anaconda2anaconda3/lib``) that only conda's post-link script rewrites.
The ICD loader (ocl-icd, which pyopencl's wheel bundles; the Khronos loader reads the
same variable) reads the ``.icd`` files of one directory: ``OCL_ICD_VENDORS`` if set,
else ``OPENCL_VENDOR_PATH`` (ocl-icd), else ``/etc/OpenCL/vendors``. pyopencl's
wheel patches it to read its own ``pyopencl/.libs/*.icd`` (PoCL from
``pyopencl[pocl]``) as well, whatever that directory is.

At import (before the loader's first call, which is when it reads the variables),
:func:`register` finds the wheel's ``libintelocl.so`` and, unless something below
stops it, writes a directory of ``.icd`` files into texray's cache
(``$XDG_CACHE_HOME/texray/icd/<hash>``, else ``~/.cache/texray/icd/<hash>``, else the
temporary directory) listing

* every ICD of the directory the loader reads now (``OCL_ICD_VENDORS``'s directory
  when the user set one, else ``OPENCL_VENDOR_PATH``'s or ``/etc/OpenCL/vendors``);
* every ICD of the environment's own ``sys.prefix/etc/OpenCL/vendors`` (the default
  directory of conda's loader), so that no device visible before is hidden;
* ``intel-cpu.icd`` naming the found library, ``nvidia.icd`` naming NVIDIA's,

and points ``OCL_ICD_VENDORS`` at it. pyopencl's own ``.libs`` ICDs are not copied
(its loader reads them anyway: a copy would list PoCL twice). An ICD naming an absolute
path that does not exist (those conda placeholders) is left out: it never loaded.

Nothing is changed (the environment is left as it is) when

* ``TEXRAY_NO_ICD`` is set to anything but ``""`` or ``"0"`` (a registration inherited from
  a parent process, which leaves ``TEXRAY_ICD_VENDORS`` and ``TEXRAY_ICD_VENDORS_BEFORE``
  in the environment, is then undone: :func:`undo`);
* neither is found: the wheel is not installed (no ``libintelocl.so``) and no NVIDIA
  library is found, or the loader's directory names each found one already;
* the user's ``OCL_ICD_VENDORS`` names a file, not a directory (the loader then loads
  that one ICD only: an explicit choice of one driver);
* a ``libintelocl.so`` is registered already in the directory the loader reads
  (a system-wide install, or this function's own directory inherited by a child
  process), and so is NVIDIA's library where it is found;
* the cache directory cannot be written.

``PYOPENCL_CTX`` and ``device=`` still choose among the devices. Registration does not
help a process that queried OpenCL platforms before importing texray (the loader
reads its variables once).
"""
from __future__ import annotations

import hashlib
import importlib.metadata
import os
import sys
import tempfile
from pathlib import Path

DISTRIBUTION = "intel-opencl-rt"
LIBRARY = "libintelocl.so"
SYSTEM_VENDORS = Path("/etc/OpenCL/vendors")
NVIDIA_LIBRARY = "libnvidia-opencl.so.1"
NVIDIA_DIRS = ("/usr/local/nvidia/lib64", "/usr/local/nvidia/lib", "/usr/lib/x86_64-linux-gnu",
               "/usr/lib/aarch64-linux-gnu", "/usr/lib64", "/usr/lib")
"""Where NVIDIA's driver libraries are mounted (container runtimes, Kubernetes' device
plugin) or installed (Debian/Ubuntu multiarch, RPM distributions), after LD_LIBRARY_PATH."""


def find_runtime() -> Path | None:
    """The ``libintelocl.so`` the ``intel-opencl-rt`` wheel installed, or None."""
    try:
        dist = importlib.metadata.distribution(DISTRIBUTION)
    except importlib.metadata.PackageNotFoundError:
        return None
    for f in dist.files or ():
        if f.name == LIBRARY:
            p = Path(os.path.normpath(dist.locate_file(f)))
            if p.is_file():
                return p
    return None


def find_nvidia(environ=None, dirs=None) -> Path | None:
    """NVIDIA's ``libnvidia-opencl.so.1``: the first in ``LD_LIBRARY_PATH``'s directories,
    then :data:`NVIDIA_DIRS` (``dirs`` replaces both), or None."""
    environ = os.environ if environ is None else environ
    if dirs is None:
        dirs = [*(environ.get("LD_LIBRARY_PATH") or "").split(os.pathsep), *NVIDIA_DIRS]
    for d in dirs:
        if d and os.path.isabs(d):
            p = Path(d) / NVIDIA_LIBRARY
            if p.is_file():
                return p
    return None


def _icd_files(directory: Path) -> list[Path]:
    try:
        return sorted(p for p in directory.iterdir() if p.suffix == ".icd" and p.is_file())
    except OSError:
        return []


def _library(icd: Path) -> str | None:
    """The library an ICD file names (its first non-empty line), or None if unreadable."""
    try:
        lines = [ln.strip() for ln in icd.read_text(errors="replace").splitlines()]
    except OSError:
        return None
    return next((ln for ln in lines if ln), None)


def _loader_dir(environ) -> Path | None:
    """The directory the ICD loader reads now; None when OCL_ICD_VENDORS names a file."""
    user = environ.get("OCL_ICD_VENDORS")
    if user:
        return Path(user) if Path(user).is_dir() else None
    return Path(environ.get("OPENCL_VENDOR_PATH") or SYSTEM_VENDORS)


def cache_root(environ) -> Path:
    """Where the vendor directories go: ``$XDG_CACHE_HOME/texray/icd`` or ``~/.cache/texray/icd``."""
    base = environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "texray" / "icd"


def _write_vendor_dir(root: Path, entries: list[tuple[str, str]]) -> Path:
    """A directory under root holding one ``name.icd`` per (name, library) entry, named by
    the hash of its contents (shared by every process that needs the same list; written
    to a temporary directory and renamed into place, so a reader never sees it half
    written). Raises OSError when root cannot be written."""
    text = "".join(f"{name}\n{lib}\n" for name, lib in entries)
    final = root / hashlib.sha256(text.encode()).hexdigest()[:16]
    if all(_library(final / name) == lib for name, lib in entries):
        return final
    root.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".tmp-", dir=root))
    for name, lib in entries:
        (tmp / name).write_text(lib + "\n")
    try:
        os.replace(tmp, final)
    except OSError:                       # another process put the same directory in place
        for p in tmp.iterdir():
            p.unlink()
        tmp.rmdir()
        if not all(_library(final / name) == lib for name, lib in entries):
            raise
    return final


def register(environ=None, library=None, cache_dir=None, prefix_vendors=None, nvidia_dirs=None) -> Path | None:
    """Make ``library`` (default :func:`find_runtime`) and NVIDIA's OpenCL driver
    (:func:`find_nvidia` over ``nvidia_dirs``) visible to the ICD loader besides every ICD
    visible now, by pointing ``environ["OCL_ICD_VENDORS"]`` (default ``os.environ``) at a
    vendor directory under ``cache_dir`` (default :func:`cache_root`, then the temporary
    directory). ``prefix_vendors`` is the environment's own vendor directory (default
    ``sys.prefix/etc/OpenCL/vendors``). Returns that directory, or None where it changes
    nothing (module docstring)."""
    environ = os.environ if environ is None else environ
    if environ.get("TEXRAY_NO_ICD", "") not in ("", "0"):
        undo(environ)              # a registration inherited from a parent process: undone too
        return None
    library = find_runtime() if library is None else Path(library)
    nvidia = find_nvidia(environ, nvidia_dirs)
    # (ICD file name, what an ICD's library name starts with when it is that driver, the library)
    wanted = [w for w in (("intel-cpu.icd", LIBRARY, library), ("nvidia.icd", NVIDIA_LIBRARY.split(".")[0], nvidia))
              if w[2] is not None]
    if not wanted:
        return None
    loader_dir = _loader_dir(environ)
    if loader_dir is None:
        return None
    if prefix_vendors is None:
        prefix_vendors = Path(sys.prefix) / "etc" / "OpenCL" / "vendors"
    entries, seen = [], set()
    for k, directory in enumerate(dict.fromkeys([loader_dir, Path(prefix_vendors)])):
        for icd in _icd_files(directory):
            lib = _library(icd)
            if lib is None or lib in seen or (os.path.isabs(lib) and not os.path.exists(lib)):
                continue
            base = os.path.basename(lib)
            if k == 1 and base == LIBRARY:
                continue                  # ours replaces the environment's own
            wanted = [w for w in wanted if not base.startswith(w[1])]     # listed already: not added again
            seen.add(lib)
            entries.append((f"{len(entries):02d}-{icd.name}", lib))
    if not wanted:
        return None
    entries += [(f"{len(entries) + i:02d}-{name}", str(lib)) for i, (name, _, lib) in enumerate(wanted)]
    if cache_dir is not None:
        roots = [Path(cache_dir)]
    else:
        uid = os.getuid() if hasattr(os, "getuid") else 0
        roots = [cache_root(environ), Path(tempfile.gettempdir()) / f"texray-icd-{uid}"]
    for root in roots:
        try:
            vendors = _write_vendor_dir(root, entries)
        except OSError:
            continue
        environ[_BEFORE] = environ.get("OCL_ICD_VENDORS", "")
        environ["OCL_ICD_VENDORS"] = environ[_REGISTERED] = str(vendors)
        return vendors
    return None


# What a registration leaves in the environment besides OCL_ICD_VENDORS, for child processes
# (which inherit it and then register nothing: their loader directory lists the runtime):
# the directory registered and OCL_ICD_VENDORS before it ("" where it was unset).
_REGISTERED, _BEFORE = "TEXRAY_ICD_VENDORS", "TEXRAY_ICD_VENDORS_BEFORE"


def undo(environ) -> None:
    """Take texray's registration out of ``environ`` (this process's, or one inherited from a
    parent): ``OCL_ICD_VENDORS`` as it was before. Nothing where ``OCL_ICD_VENDORS`` was
    changed since (the user's choice stands)."""
    registered_dir = environ.pop(_REGISTERED, None)
    before = environ.pop(_BEFORE, None)
    if registered_dir is None or before is None or environ.get("OCL_ICD_VENDORS") != registered_dir:
        return
    if before:
        environ["OCL_ICD_VENDORS"] = before
    else:
        environ.pop("OCL_ICD_VENDORS", None)


def without_registration(environ=None) -> dict:
    """A copy of ``environ`` (default ``os.environ``) without texray's registration
    (:func:`undo`): the environment for a child process that must not see the runtimes
    registered here."""
    env = dict(os.environ if environ is None else environ)
    undo(env)
    return env


registered = register()
"""The vendor directory this process registered at import, or None (module docstring)."""
