"""Fuzz cases for texray (issue 12: nothing crashes, hangs or returns NaN).

A texray call on any input must end in exactly one of: success with finite pixels
(``image.rgb`` finite; AOVs finite where the ray hits, NaN exactly where it misses, ids -1
there), or a ``texray.SceneError`` / ``DeviceError`` / ``BuildError``. Errors raised while
loading a scene file must name the file.

Layout of this module:

* **Choosers**: the generators draw every decision through a small interface,
  ``integer(lo, hi)``, ``choice(seq)``, ``floats(lo, hi)``, ``boolean(p)``, with two
  backends: :class:`RandomChooser` over ``random.Random`` (``tools/fuzz.py``: case k of
  campaign seed S is ``RandomChooser(f"{S}:{k}")``, so ``--seed S --case k`` replays it) and
  :class:`HypothesisChooser` over hypothesis's ``data.draw`` (``tests/fuzz/test_fuzz.py``, so
  hypothesis shrinks findings).
* **Generators**, one per family (:data:`FAMILIES`): ``scene_file`` (mutated shipped TOML
  scenes, through ``Scene.load`` + ``render`` or the CLI), ``geometry`` (the API's
  constructors with odd arrays and parameters), ``texture`` (``Texture.from_array`` /
  ``procedural`` / ``load`` and the material roles), ``render_args`` (``render``'s own
  arguments, devices, ``PYOPENCL_CTX``) and ``random_scene`` (valid scenes mixing every
  feature at extreme placements: they must render). Each returns a :class:`Case` whose
  ``code`` is a short Python program: the exact input, runnable on its own
  (``python tools/fuzz.py --seed S --case k`` prints and runs it).
* **Execution**: :func:`execute` runs a case's code and classifies what happened
  (:data:`OK_KINDS`, :data:`FINDING_KINDS`). :class:`Worker` runs cases in a persistent child
  process (``python tests/fuzz_cases.py --serve``) with a per-case time limit and a memory
  limit, restarted after a crash or a hang so that each is attributed to its case.
"""
from __future__ import annotations

import contextlib
import copy
import io
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from dataclasses import asdict, dataclass, field
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:          # Python < 3.11
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"
nan, inf = float("nan"), float("inf")

# Outcomes that meet the contract, and the findings.
OK_KINDS = ("ok", "scene_error", "device_error", "build_error", "cli_error", "cli_usage")
FINDING_KINDS = ("crash", "hang", "nonfinite", "bad_aov", "wrong_exception", "error_without_file",
                 "silent_accept", "rejected_valid", "seed_alias", "bad_exit", "bad_message", "harness_error")
# Scenes too slow for a fuzz case (1M triangles) are skipped.
SKIP_SCENES = ("bench/mesh1m.toml",)
CASE_FILE = "<fuzz-case>"


# =============================================================================
# Choosers
# =============================================================================

class RandomChooser:
    """Decisions from ``random.Random(seed)`` (a str seed is hashed with SHA-512: the same on
    every machine and Python run)."""

    def __init__(self, seed):
        import random
        self.r = random.Random(seed)

    def integer(self, lo, hi):
        return self.r.randint(lo, hi)

    def choice(self, seq):
        seq = list(seq)
        return seq[self.r.randrange(len(seq))]

    def floats(self, lo, hi):
        return self.r.uniform(lo, hi)

    def boolean(self, p=0.5):
        return self.r.random() < p


class HypothesisChooser:
    """Decisions from hypothesis's ``data.draw``: shrinking moves integers toward ``lo``,
    choices toward the first element and booleans toward False, so list the plain values
    first."""

    def __init__(self, data):
        from hypothesis import strategies as st
        self.d, self.st = data, st

    def integer(self, lo, hi):
        return self.d.draw(self.st.integers(lo, hi))

    def choice(self, seq):
        return self.d.draw(self.st.sampled_from(list(seq)))

    def floats(self, lo, hi):
        return self.d.draw(self.st.floats(lo, hi, allow_nan=False, allow_infinity=False))

    def boolean(self, p=0.5):
        return self.d.draw(self.st.integers(0, 999)) >= 1000 - int(round(1000 * p))


def weighted(ch, options):
    """One value of ``options`` = [(weight, value), ...] (integer weights)."""
    total = sum(w for w, _ in options)
    x = ch.integer(0, total - 1)
    for w, v in options:
        if x < w:
            return v
        x -= w
    return options[-1][1]


# =============================================================================
# Python source for the cases
# =============================================================================

class Code(str):
    """A piece of Python source, written as is by :func:`lit`."""


def _float_text(v) -> str:
    """A float as Python and TOML both write it, nan and +-inf by name."""
    if math.isnan(v):
        return "nan"
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return repr(v)


def lit(v) -> str:
    """``v`` as Python source (nan/inf as the names ``nan``/``inf`` of the case namespace)."""
    if isinstance(v, Code):
        return str(v)
    if isinstance(v, bool) or v is None or isinstance(v, (int, str, bytes)):
        return repr(v)
    if isinstance(v, float):
        return _float_text(v)
    if isinstance(v, complex):
        return repr(v)
    if isinstance(v, list):
        return "[" + ", ".join(lit(x) for x in v) + "]"
    if isinstance(v, tuple):
        return "(" + ", ".join(lit(x) for x in v) + ("," if len(v) == 1 else "") + ")"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{lit(k)}: {lit(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"lit: {type(v).__name__}")


def call(fn, *args, **kwargs) -> Code:
    parts = [lit(a) for a in args] + [f"{k}={lit(v)}" for k, v in kwargs.items()]
    return Code(f"{fn}({', '.join(parts)})")


def r3(x):
    """A float rounded to 3 decimals (short, exact source)."""
    return round(float(x), 3)


# =============================================================================
# TOML writer (own, so that a case's text is the same on every machine)
# =============================================================================

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def _toml_key(k):
    return k if _BARE_KEY.match(k) else _toml_str(k)


def _toml_str(s):
    out = ['"']
    for c in s:
        if c in '"\\':
            out.append("\\" + c)
        elif ord(c) < 0x20 or ord(c) == 0x7F:
            out.append(f"\\u{ord(c):04x}")
        else:
            out.append(c)
    out.append('"')
    return "".join(out)


def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return _float_text(v)
    if isinstance(v, str):
        return _toml_str(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + " }" if v else "{}"
    raise TypeError(f"TOML cannot hold {type(v).__name__} {v!r}")


def _array_of_tables(v):
    return isinstance(v, list) and v and all(isinstance(x, dict) for x in v)


def toml_dumps(doc: dict) -> str:
    """TOML text of ``doc``: top-level tables as [sections] (their tables inline), lists of
    tables as [[sections]]; nan/inf as TOML's nan/inf."""
    lines = [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in doc.items()
             if not isinstance(v, dict) and not _array_of_tables(v)]
    for k, v in doc.items():
        if isinstance(v, dict):
            lines.append(f"\n[{_toml_key(k)}]")
            lines.extend(f"{_toml_key(kk)} = {_toml_value(vv)}" for kk, vv in v.items())
        elif _array_of_tables(v):
            for item in v:
                lines.append(f"\n[[{_toml_key(k)}]]")
                lines.extend(f"{_toml_key(kk)} = {_toml_value(vv)}" for kk, vv in item.items())
    return "\n".join(lines).lstrip("\n") + "\n"


def _text_literal(text):
    """``text`` as a readable triple-quoted Python literal when possible."""
    if "'''" not in text and "\\" not in text and not text.endswith("'"):
        return "'''\\\n" + text + "'''"
    return repr(text)


# =============================================================================
# The case and the helpers its code calls
# =============================================================================

@dataclass
class Case:
    """One fuzz input: ``code`` (Python, run by :func:`execute`) sets ``RESULT`` to an
    Image, a list of Images or a :class:`CliResult`. ``must_reject``: why the input is
    invalid (success is then a finding, ``silent_accept``); ``must_succeed``: the input is
    valid (a texray error is then ``rejected_valid``); ``differ``: RESULT is [A, B, C] with B
    rendered with A's seed + 2**32 and C with A's seed + 1: B == A != C is ``seed_alias``;
    ``env``: environment variables set while the case runs (in the worker only)."""
    family: str
    code: str
    must_reject: str | None = None
    must_succeed: bool = False
    differ: bool = False
    env: dict = field(default_factory=dict)
    label: str = ""
    tags: str = ""          # what the generator chose that matters for grouping findings

    def source(self) -> str:
        """The case as a stand-alone program (run it with tests/ on sys.path)."""
        head = [f"# texray fuzz case {self.label} ({self.family})".rstrip()]
        if self.must_reject:
            head.append(f"# invalid input, must raise a texray error: {self.must_reject}")
        if self.must_succeed:
            head.append("# valid input: must render with finite pixels")
        if self.env:
            head.append(f"# environment: {' '.join(f'{k}={v!r}' for k, v in self.env.items())}")
        return "\n".join(head) + "\n" + self.code


class Finding(Exception):
    """Raised by a helper of the case namespace when it sees a broken contract."""

    def __init__(self, kind, detail):
        super().__init__(f"{kind}: {detail}")
        self.kind, self.detail = kind, detail


_TMP = [None]      # the running case's directory


def tmp(name="") -> str:
    """A path in the case's temporary directory."""
    return str(Path(_TMP[0]) / name) if name else str(_TMP[0])


def asset(rel) -> str:
    """The absolute path of a shipped asset, ``rel`` relative to scenes/."""
    return str(SCENES / rel)


def random_bytes(name, n, seed) -> str:
    import numpy as np
    p = Path(tmp(name))
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_bytes(np.random.default_rng(seed).integers(0, 256, n, dtype=np.uint8).tobytes())
    return str(p)


def truncated(name, src, fraction) -> str:
    """A copy of the first ``fraction`` of asset ``src``'s bytes."""
    data = Path(asset(src)).read_bytes()
    p = Path(tmp(name))
    p.write_bytes(data[:int(len(data) * fraction)])
    return str(p)


def copy_asset(name, src) -> str:
    p = Path(tmp(name))
    shutil.copyfile(asset(src), p)
    return str(p)


def fifo(name) -> str:
    p = Path(tmp(name))
    os.mkfifo(p)
    return str(p)


def directory(name) -> str:
    p = Path(tmp(name))
    p.mkdir(parents=True, exist_ok=True)
    return str(p)


def write_text(name, text) -> str:
    p = Path(tmp(name))
    p.write_text(text, encoding="utf-8")
    return str(p)


def write_bytes(name, data) -> str:
    p = Path(tmp(name))
    p.write_bytes(data)
    return str(p)


def write_image(name, array, dtype="float") -> str:
    """An image file written by OpenImageIO from a numpy array (any channel count, NaN...)."""
    import numpy as np
    import OpenImageIO as oiio
    a = np.asarray(array, dtype=np.float32)
    a = a.reshape(a.shape[0], a.shape[1], -1)
    p = tmp(name)
    out = oiio.ImageOutput.create(p)
    if out is None:
        raise RuntimeError(f"harness: cannot write {p}: {oiio.geterror()}")
    out.open(p, oiio.ImageSpec(a.shape[1], a.shape[0], a.shape[2], dtype))
    out.write_image(a)
    out.close()
    return p


def load_scene(path):
    """tx.Scene.load, and every SceneError must name the file."""
    import texray as tx
    try:
        return tx.Scene.load(path)
    except tx.SceneError as e:
        if str(path) not in str(e):
            raise Finding("error_without_file", f"SceneError without the file's path: {_first(e)}") from None
        raise


def render_settings(scene, specialize=True, **kw):
    """Render like the CLI: the scene file's [render] table (default 16x16, 1 spp)."""
    import texray as tx
    s = getattr(scene, "render_settings", {})
    return tx.render(scene, s.get("width", 16), s.get("height", 16), s.get("spp", 1), seed=s.get("seed", 0),
                     specialize=specialize, **kw)


@dataclass
class CliResult:
    argv: list
    rc: object
    stdout: str
    stderr: str
    usage: bool = False      # SystemExit from argparse


def cli(argv):
    """texray.cli.main(argv) with stdout/stderr captured. A texray error must exit 2 with
    "texray: error:"; an error of the scene file must name it; other exceptions propagate."""
    from texray.cli import main
    out, err = io.StringIO(), io.StringIO()
    usage = False
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            rc = main(list(argv))
        except SystemExit as e:
            rc, usage = e.code, True
    res = CliResult(list(argv), rc, out.getvalue(), err.getvalue(), usage)
    if rc == 2 and not usage and len(argv) > 1 and argv[0] == "render":
        import texray as tx
        try:
            tx.Scene.load(argv[1])
        except tx.SceneError:
            if str(argv[1]) not in res.stderr:
                raise Finding("error_without_file", f"CLI error without the scene file's path: "
                              f"{res.stderr.strip()[:300]}") from None
        except Exception:
            pass
    return res


def _first(e, limit=300):
    s = str(e).strip().splitlines()
    s = s[0] if s else ""
    return s if len(s) <= limit else s[:limit] + "..."


def namespace():
    import numpy as np
    import texray as tx
    import texray.compile
    import texray.procedural
    return {"tx": tx, "texray": tx, "np": np, "nan": nan, "inf": inf, "procedural": tx.procedural,
            "tmp": tmp, "asset": asset, "random_bytes": random_bytes, "truncated": truncated,
            "copy_asset": copy_asset, "fifo": fifo, "directory": directory, "write_text": write_text,
            "write_bytes": write_bytes,
            "write_image": write_image, "load_scene": load_scene, "render_settings": render_settings, "cli": cli,
            "__name__": "__fuzz_case__"}


# =============================================================================
# Execution and classification
# =============================================================================

def _where(tb):
    """'file.py:line function' of the innermost texray frame (else the innermost frame)."""
    frames = traceback.extract_tb(tb)
    tx = [f for f in frames if "/texray/" in f.filename.replace(os.sep, "/")]
    f = tx[-1] if tx else (frames[-1] if frames else None)
    if f is None:
        return ""
    return f"{Path(f.filename).name}:{f.lineno} {f.name}"


def _check_image(img, where="RESULT"):
    import numpy as np
    import texray as tx
    if not isinstance(img, tx.Image):
        raise Finding("harness_error", f"{where} is {type(img).__name__}, not an Image")
    if img.rgb is not None:
        rgb = np.asarray(img.rgb)
        bad = ~np.isfinite(rgb)
        if bad.any():
            y, x, c = np.argwhere(bad)[0]
            what = "NaN" if np.isnan(rgb).any() else "inf"
            raise Finding("nonfinite", f"rgb {what}: {int(bad.any(-1).sum())} of {rgb.shape[0] * rgb.shape[1]} "
                          f"pixels non-finite, first ({y}, {x}) = {rgb[y, x].tolist()}")
    miss, miss_from = None, None
    for name, a in (img.aov or {}).items():
        a = np.asarray(a)
        if name in ("primitive_id", "object_id"):
            v = a[..., 0]
            m = v == -1
            badv = ~m & ~(np.isfinite(v) & (v >= 0) & (v == np.floor(v)))
            if badv.any():
                y, x = np.argwhere(badv)[0]
                raise Finding("bad_aov", f"aov {name}: ({y}, {x}) = {v[y, x]!r}, neither -1 nor an id")
        else:
            m = np.isnan(a).all(-1)
            badv = ~(m | np.isfinite(a).all(-1))
            if badv.any():
                y, x = np.argwhere(badv)[0]
                raise Finding("nonfinite", f"aov {name} {'NaN' if np.isnan(a).any() else 'inf'}: {int(badv.sum())} hit pixels non-finite, first "
                              f"({y}, {x}) = {a[y, x].tolist()}")
        if miss is None:
            miss, miss_from = m, name
        elif (m != miss).any():
            y, x = np.argwhere(m != miss)[0]
            raise Finding("bad_aov", f"aovs {miss_from} and {name} disagree on hit/miss at ({y}, {x}): "
                          f"{miss_from} {'miss' if miss[y, x] else 'hit'}, {name} {'miss' if m[y, x] else 'hit'}")


def _check_result(case, result):
    """Raise Finding for a broken contract of a finished case; else the ok kind."""
    import numpy as np
    if isinstance(result, CliResult):
        if result.usage:
            if result.rc in (0, None) and "--help" not in result.argv:
                raise Finding("bad_exit", f"argparse exited {result.rc!r}")
            return "cli_usage"
        if result.rc == 0:
            return "ok"
        if result.rc == 2 and "texray: error:" in result.stderr:
            return "cli_error"
        raise Finding("bad_exit", f"exit {result.rc!r}, stderr {result.stderr.strip()[:300]!r}")
    images = result if isinstance(result, (list, tuple)) else [result]
    for i, img in enumerate(images):
        _check_image(img, f"RESULT[{i}]")
    if case.get("differ"):
        a, b, c = images
        if np.array_equal(a.rgb, b.rgb) and not np.array_equal(a.rgb, c.rgb):
            raise Finding("seed_alias", "seeds s and s + 2**32 give the same image (s + 1 does not)")
    return "ok"


def execute(case: dict) -> dict:
    """Run one case (a :class:`Case` as a dict) in this process and classify it: returns
    {kind, detail, exc_type, where, seconds}."""
    import texray as tx
    t0 = time.perf_counter()
    saved_env = {k: os.environ.get(k) for k in case.get("env", {})}
    os.environ.update(case.get("env", {}))
    _TMP[0] = tempfile.mkdtemp(prefix="texray-fuzz-case-")
    out = {"kind": "ok", "detail": "", "exc_type": "", "where": ""}
    try:
        ns = namespace()
        try:
            code = compile(case["code"], CASE_FILE, "exec")
            with _quiet_warnings():
                exec(code, ns)
            kind = _check_result(case, ns.get("RESULT"))
            out["kind"] = kind
            if kind in ("ok",) and case.get("must_reject"):
                out.update(kind="silent_accept", detail=f"accepted: {case['must_reject']}")
        except Finding as f:
            out.update(kind=f.kind, detail=f.detail, where=_where(f.__traceback__))
        except (KeyboardInterrupt, SystemExit) as e:
            out.update(kind="wrong_exception", exc_type=type(e).__name__, detail=_first(e),
                       where=_where(e.__traceback__))
        except BaseException as e:            # noqa: BLE001 (classifying is the point)
            frames = traceback.extract_tb(e.__traceback__)
            kinds = ((tx.SceneError, "scene_error"), (tx.DeviceError, "device_error"), (tx.BuildError, "build_error"))
            kind = next((k for t, k in kinds if isinstance(e, t)), "wrong_exception")
            if frames and frames[-1].filename == CASE_FILE and kind == "wrong_exception":
                kind = "harness_error"         # raised by the case's own code, never inside texray
            out.update(kind=kind, exc_type=type(e).__name__, detail=_first(e), where=_where(e.__traceback__))
            if kind == "harness_error":
                out["detail"] += " | " + "".join(traceback.format_exception(e)[-3:])[-600:]
        if out["kind"] in ("scene_error", "device_error", "build_error") and "No module named" in out["detail"]:
            out.update(kind="bad_message", detail=f"{out['exc_type']} blames a missing module: {out['detail']}")
        if out["kind"] in ("scene_error", "device_error", "build_error", "cli_error", "cli_usage") \
                and case.get("must_succeed"):
            out.update(kind="rejected_valid", detail=f"{out['exc_type'] or out['kind']}: {out['detail']}")
    finally:
        for key in ("detail", "where"):        # the case's directory is random: name it $TMP
            out[key] = out[key].replace(_TMP[0], "$TMP")
        for k, v in saved_env.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        shutil.rmtree(_TMP[0], ignore_errors=True)
        _TMP[0] = None
    out["seconds"] = time.perf_counter() - t0
    return out


@contextlib.contextmanager
def _quiet_warnings():
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


def is_finding(outcome) -> bool:
    return outcome["kind"] in FINDING_KINDS


def signature(outcome) -> str:
    """A grouping key: the kind, the exception type and where texray raised it."""
    parts = [outcome["kind"], outcome.get("exc_type", ""), outcome.get("where", "")]
    detail = outcome.get("detail", "")
    if outcome["kind"] == "nonfinite":
        parts = [outcome["kind"], detail.split(":")[0]]
    elif outcome["kind"] in ("bad_aov", "silent_accept", "seed_alias", "rejected_valid",
                             "error_without_file", "bad_exit", "bad_message"):
        parts.append(re.sub(r"[-+]?\d[\d.e+-]*", "#", detail)[:90])
    if outcome["kind"] in ("nonfinite", "crash", "hang") and outcome.get("tags"):
        parts.append(outcome["tags"])
    return " | ".join(p for p in parts if p)


# =============================================================================
# Worker processes
# =============================================================================

MEM_LIMIT = int(os.environ.get("TEXRAY_FUZZ_MEM", str(6 << 30)))     # bytes of address space per worker


class Worker:
    """A persistent child process running cases one after another. ``run`` returns the
    outcome; a crash (the child dies) or a hang (no answer in ``timeout`` s: the child is
    killed) is the outcome of the case that was running, and the next case starts a new
    child. The child's stdout/stderr (with faulthandler tracebacks) go to ``log_path``."""

    def __init__(self, mem_limit=MEM_LIMIT, log_path=None):
        self.mem_limit = mem_limit
        self.proc = None
        # The child's TMPDIR: the cases' directories live there, so that those of a crashed or
        # killed case go too when the worker is closed.
        self.tmpdir = tempfile.mkdtemp(prefix="texray-fuzz-worker-")
        self.log_path = log_path or os.path.join(self.tmpdir, "worker.log")
        self.cases_run = 0

    def start(self):
        from multiprocessing.connection import Connection
        self.close()
        r1, w1 = os.pipe()
        r2, w2 = os.pipe()
        self.log = open(self.log_path, "ab")
        from texray.device import icd
        env = icd.without_registration()      # this process's registration, or an inherited one
        env.pop("PYOPENCL_CTX", None)
        # Not Intel's OpenCL CPU runtime (texray[intel], which .ci/run installs): its
        # compiler takes about a minute for the generic program, beyond a case's timeout,
        # and cases that pick devices by index or PYOPENCL_CTX would reach it. The fuzz
        # suite tests texray's handling of inputs; tests/portability covers that runtime.
        env["TEXRAY_NO_ICD"] = "1"
        env["PYTHONFAULTHANDLER"] = "1"
        env["TMPDIR"] = self.tmpdir
        self.proc = subprocess.Popen([sys.executable, str(Path(__file__).resolve()), "--serve", str(r1), str(w2),
                                      str(self.mem_limit)], pass_fds=(r1, w2), stdin=subprocess.DEVNULL,
                                     stdout=self.log, stderr=subprocess.STDOUT, env=env, cwd=str(ROOT))
        os.close(r1)
        os.close(w2)
        self.tx, self.rx = Connection(w1, readable=False), Connection(r2, writable=False)

    def run(self, case, timeout=60.0) -> dict:
        if isinstance(case, Case):
            case = asdict(case)
        if self.proc is None or self.proc.poll() is not None:
            self.start()
        self.log.flush()
        offset = os.path.getsize(self.log_path)
        t0 = time.perf_counter()
        try:
            self.tx.send(dict(case, timeout=timeout))
            ready = self.rx.poll(timeout)
            out = self.rx.recv() if ready else None
        except (EOFError, OSError, BrokenPipeError):
            ready, out = True, None
        self.cases_run += 1
        if out is not None:
            out.setdefault("tags", case.get("tags", ""))
            return out
        seconds = time.perf_counter() - t0
        if not ready:                              # a hang: kill the child
            self.proc.kill()
            self.proc.wait()
            kind, detail = "hang", f"no result within {timeout:g} s"
        else:
            rc = self.proc.wait()
            kind = "crash"
            detail = f"worker died: {_signal_name(rc)}"
        tail = self._log_since(offset)
        self.close()
        return {"kind": kind, "detail": detail, "exc_type": "", "where": _where_from_dump(tail),
                "seconds": seconds, "log": tail[-4000:], "tags": case.get("tags", "")}

    def _log_since(self, offset):
        try:
            with open(self.log_path, "rb") as f:
                f.seek(offset)
                return f.read().decode("utf-8", "replace")
        except OSError:
            return ""

    def close(self):
        if self.proc is not None:
            try:
                self.tx.close()
            except OSError:
                pass
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
            self.rx.close()
            self.log.close()
            self.proc = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        with contextlib.suppress(OSError):
            os.unlink(self.log_path)
        shutil.rmtree(self.tmpdir, ignore_errors=True)


def _signal_name(rc):
    if rc is not None and rc < 0:
        try:
            return f"signal {signal.Signals(-rc).name}"
        except ValueError:
            return f"signal {-rc}"
    return f"exit code {rc}"


def _where_from_dump(text):
    """The innermost texray frame of the last faulthandler dump in ``text``."""
    blocks = re.split(r"(?:Fatal Python error|Timeout \(|Current thread|Thread 0x)", text)
    for block in reversed(blocks):
        frames = re.findall(r'File "([^"]+)", line (\d+) in (\S+)', block)
        if not frames:
            continue
        tx = [f for f in frames if "/texray/" in f[0]]
        f = tx[0] if tx else frames[0]          # faulthandler lists the innermost frame first
        return f"{Path(f[0]).name}:{f[1]} {f[2]}"
    return ""


def _serve(rfd, wfd, mem_limit):
    import faulthandler
    import resource
    from multiprocessing.connection import Connection
    if mem_limit > 0:
        resource.setrlimit(resource.RLIMIT_AS, (mem_limit, mem_limit))
    faulthandler.enable(all_threads=True)
    rx, txc = Connection(rfd, writable=False), Connection(wfd, readable=False)
    import texray  # noqa: F401  (pay the import once)
    while True:
        try:
            case = rx.recv()
        except EOFError:
            return
        print(f"=== case {case.get('label', '')} ({case.get('family')})", flush=True)
        faulthandler.dump_traceback_later(max(1.0, 0.9 * case.get("timeout", 60)), exit=False)
        try:
            out = execute(case)
        finally:
            faulthandler.cancel_dump_traceback_later()
        sys.stdout.flush()
        sys.stderr.flush()
        txc.send(out)


# =============================================================================
# Value pools
# =============================================================================

EXTREME_NUMBERS = [0, -1, 1e-45, 1e-300, 1e39, 1e308, -1e308, nan, inf, -inf, 2**63, 2**32, -2**63, 1e-9, 0.5]
# Values of the [render] table and render()'s sizes: extremes that are errors, never a legit huge render.
EXTREME_COUNTS = [0, -1, 2**63, 2**32, -2**63, 1e39, nan, 1.5, 2**64 + 3]
WRONG_TYPES = ["abc", "", True, 7, 1.5, [], [1, 2], {"x": 1}, {}, [[1, 2, 3]], [{"a": 1}]]
STRINGS = ["", "mesh", "sphere", "cylinder", "quad", "procedural", "nearest", "bilinear", "trilinear", "anisotropic",
           "repeat", "clamp", "mirror", "srgb", "linear", "auto", "search", "maxmip", "tessellate", "opengl",
           "directx", "tangent", "object", "planar", "cylindrical", "spherical", "analytic", "checker", "bricks",
           "bricks_height", "noise", "wood", "marble", "tiles", "globe", "label", "uv_sphere", "torus", "grid",
           "vase", "bench_mesh", "SRGB", " sphere", "nonexistent"]
BAD_VEC3 = [(0, 0, 0), (nan, 0, 0), (inf, 0, 0), (0, -inf, 0), (1e39, 0, 0), (1e308, 1e308, 1e308),
            (-1e308, 0, 1e308), (1e-300, 1e-300, 1e-300), (1e-45, 0, 0), (1e19, 0, 0), (3e38, 3e38, 3e38),
            [1, 2], [1, 2, 3, 4], [[1, 2], [3]], [[1, 2, 3]], "abc", "", None, 5, -1, 1e39, nan, True,
            (1, "a", 3), {"x": 1}, [], (2**63, 0, 0), Code("np.array([1, 2, 3], dtype=object)"),
            Code("np.array([1 + 1j, 0, 0])"), Code("np.float32([1e38, 1e38, 1e38])"),
            Code("np.array([[1.0, 2.0, 3.0]])"), Code("np.array(['1', '2', '3'])")]
BAD_NUMBER = [0, -1, 1e-45, 1e-300, 1e39, 1e308, -1e308, nan, inf, -inf, 2**63, 2**32, -2**63, 1e-9, "1", "abc",
              None, True, [1], (1, 2), Code("np.float64(nan)"), Code("np.int64(-1)"), Code("np.float32(1e38)"),
              Code("np.array(2.0)"), 1j]


def vec3(ch, lo=-3.0, hi=3.0):
    return (r3(ch.floats(lo, hi)), r3(ch.floats(lo, hi)), r3(ch.floats(lo, hi)))


def unit_dir(ch):
    import numpy as np
    for _ in range(10):
        v = np.array([ch.floats(-1, 1), ch.floats(-1, 1), ch.floats(-1, 1)])
        n = np.linalg.norm(v)
        if n > 0.2:
            return tuple(r3(x) for x in v / n)
    return (0.0, 0.6, 0.8)


def maybe_bad_vec(ch, good, p=0.15):
    return ch.choice(BAD_VEC3) if ch.boolean(p) else good


def maybe_bad_num(ch, good, p=0.15):
    return ch.choice(BAD_NUMBER) if ch.boolean(p) else good


def _non_finite_or_huge(v, limit=3.4e38):
    """True if the (scalar or vector) literal value has a NaN, an inf or a magnitude > limit."""
    vals = v if isinstance(v, (list, tuple)) else [v]
    for x in vals:
        if isinstance(x, (list, tuple)):
            if _non_finite_or_huge(x, limit):
                return True
        elif isinstance(x, (int, float)) and not isinstance(x, bool):
            if not math.isfinite(x) or abs(x) > limit:
                return True
    return False


def _has_negative(v):
    vals = v if isinstance(v, (list, tuple)) else [v]
    return any(isinstance(x, (int, float)) and not isinstance(x, bool) and x < 0 for x in vals)


def _is_num(x):
    return isinstance(x, (int, float)) and not isinstance(x, (bool, Code))


# =============================================================================
# Family: random valid scenes (shared builders: materials, textures, objects)
# =============================================================================

PNG_ASSETS = ["textures/checker.png", "textures/wood.png", "textures/bricks.png", "textures/label.png",
              "textures/globe.png", "textures/bricks_height.png", "textures/tiles_normal.png",
              "textures/disp_terrain.png", "textures/globe_height.png"]
OBJ_ASSETS = ["meshes/torus.obj", "meshes/vase.obj", "meshes/ground.obj"]
FILTERS = ["bilinear", "nearest", "trilinear", "anisotropic"]
WRAPS = ["repeat", "clamp", "mirror"]
AOV_NAMES = ["uv", "position", "normal", "shading_normal", "depth", "primitive_id", "object_id", "dpdu", "dpdv"]


class _Lines:
    """A growing case program with fresh variable names."""

    def __init__(self):
        self.lines, self.n = [], {}
        self.x = frozenset()        # the extreme knobs of an extreme_scene case (KNOBS)

    def add(self, line):
        self.lines.append(line)

    def var(self, prefix, expr):
        i = self.n.get(prefix, 0)
        self.n[prefix] = i + 1
        name = f"{prefix}{i}"
        self.lines.append(f"{name} = {expr}")
        return Code(name)

    def text(self):
        return "\n".join(self.lines) + "\n"


# Knobs of the extreme_scene family: valid values at the edge of what the device's float32 holds.
KNOBS = ("light_huge", "light_on_surface", "ambient_huge", "background_huge", "constants_huge", "texels_huge",
         "uv_degenerate", "normals_odd", "uvt_extreme", "bump_extreme", "disp_extreme", "proj_extreme",
         "camera_extreme", "tiny_textures", "many_lights")
HUGE = [1e20, 1e30, 1e37, 1e38, 3e38, 3.4e38]


def _valid_tex_options(ch, allow_uvt=True, x=frozenset()):
    kw = {}
    if allow_uvt and "uvt_extreme" in x and ch.boolean(0.5):
        kw["uv_transform"] = call("tx.UVTransform", scale=ch.choice([(1e6, 1e6), (1e10, 1e-10), (1e30, 1e30),
                                                                     (1e-30, 1e-30), (-1e20, 3), (3e38, 3e38)]),
                                  offset=ch.choice([(0, 0), (1e30, -1e30), (1e7, 1e7), (3e38, 0)]),
                                  rotation=ch.choice([0, 1e10, 1e300, -45.5]))
    if ch.boolean(0.6):
        kw["filter"] = ch.choice(FILTERS)
    if ch.boolean(0.4):
        kw["wrap"] = ch.choice(WRAPS)
    if allow_uvt and ch.boolean(0.3):
        kw["uv_transform"] = call("tx.UVTransform", scale=(r3(ch.floats(0.2, 6)), r3(ch.floats(0.2, 6))),
                                  offset=(r3(ch.floats(-1, 1)), r3(ch.floats(-1, 1))),
                                  rotation=r3(ch.floats(-180, 180)))
    if kw.get("filter") == "anisotropic" and ch.boolean(0.5):
        kw["max_aniso"] = ch.integer(1, 64)
    return kw


def _valid_texture(ch, L, role="colour", allow_uvt=True):
    """A valid texture variable for ``role``: colour (any), grey (1 channel), normal (3 channels)."""
    opts = _valid_tex_options(ch, allow_uvt, L.x)
    size = ch.choice([16, 32, (16, 32), 8, 64])
    if "tiny_textures" in L.x and ch.boolean(0.6):
        size = ch.choice([1, (1, 64), (64, 1), (1, 2), 2])
        if ch.boolean(0.5):
            opts["filter"] = ch.choice(["trilinear", "anisotropic"])
    if role == "grey":
        src = ch.choice(["noise", "bricks_height", "array", "file"])
        if src == "array":
            expr = call("tx.Texture.from_array", Code(f"np.random.default_rng({ch.integer(0, 99)}).random("
                                                      f"({ch.integer(2, 16)}, {ch.integer(2, 16)})).astype(np.float32)"),
                        **opts)
        elif src == "file":
            expr = call("tx.Texture.load", Code(f"asset({ch.choice(['textures/bricks_height.png', 'textures/globe_height.png', 'textures/disp_terrain.png'])!r})"),
                        colorspace="linear", **opts)
        else:
            expr = call("tx.Texture.procedural", src, size=size, **opts)
    elif role == "normal":
        if ch.boolean(0.5):
            expr = call("tx.Texture.load", Code("asset('textures/tiles_normal.png')"), colorspace="linear", **opts)
        else:
            n = ch.integer(2, 8)
            expr = call("tx.Texture.from_array", Code(
                f"np.dstack([np.random.default_rng({ch.integer(0, 99)}).uniform(0.3, 0.7, ({n}, {n}, 2)), "
                f"np.ones(({n}, {n}, 1))]).astype(np.float32)"), **opts)
    else:
        src = ch.choice(["procedural", "file", "array"])
        if "texels_huge" in L.x and ch.boolean(0.6):
            v = ch.choice([65504.0, 6e4, 1e4, -65504.0, 65000.0])
            expr = call("tx.Texture.from_array", Code(f"np.full(({ch.integer(1, 4)}, {ch.integer(1, 4)}, "
                                                      f"{ch.choice([1, 3, 4])}), {v}, np.float32)"),
                        colorspace=ch.choice(["linear", "srgb"]), **opts)
        elif src == "procedural":
            kind = ch.choice(["checker", "bricks", "noise", "wood", "marble", "tiles", "globe", "label",
                              "bricks_height"])
            expr = call("tx.Texture.procedural", kind, size=size, **opts)
        elif src == "file":
            expr = call("tx.Texture.load", Code(f"asset({ch.choice(PNG_ASSETS)!r})"), **opts)
        else:
            c = ch.choice([1, 2, 3, 4])
            expr = call("tx.Texture.from_array", Code(
                f"np.random.default_rng({ch.integer(0, 99)}).random(({ch.integer(1, 9)}, {ch.integer(1, 9)}, {c}))"
                f".astype(np.{ch.choice(['float32', 'float64', 'float16'])})"),
                colorspace=ch.choice(["linear", "srgb"]), **opts)
    return L.var("tex", expr)


def _valid_material(ch, L, kind, parallelogram=False, mapped=False, planar_convex=False):
    """A valid material for an object of ``kind`` (mesh, sphere, cylinder, quad); ``mapped``:
    the object has a projection mapping (a displaced mesh reads its height texture at its own uvs)."""
    kw = {}
    if ch.boolean(0.5):
        kw["diffuse"] = _valid_texture(ch, L)
    else:
        kw["diffuse"] = (r3(ch.floats(0, 1)), r3(ch.floats(0, 1)), r3(ch.floats(0, 1)))
    if ch.boolean(0.3):
        kw["tint"] = (r3(ch.floats(0, 1.5)), r3(ch.floats(0, 1.5)), r3(ch.floats(0, 1.5)))
    sp = ch.choice(["none", "num", "rgb", "tex"])
    if "constants_huge" in L.x and ch.boolean(0.7):
        key = ch.choice(["tint", "diffuse", "specular", "shininess"])
        v = ch.choice(HUGE) if key != "shininess" else ch.choice([0.0, 1e-45, 1e30, 3e38, 3.4e38])
        kw[key] = v if key in ("shininess", "specular") and ch.boolean(0.5) else (v,) * 3 if key != "shininess" else v
        if key == "specular":
            sp = "kept"
    if sp == "num":
        kw["specular"] = r3(ch.floats(0, 1))
    elif sp == "rgb":
        kw["specular"] = (r3(ch.floats(0, 1)), r3(ch.floats(0, 1)), r3(ch.floats(0, 1)))
    elif sp == "tex":
        kw["specular"] = _valid_texture(ch, L)
    if ch.boolean(0.5) and "shininess" not in kw:
        kw["shininess"] = r3(ch.floats(0, 200))
    if ch.boolean(0.2):
        kw["shininess_map"] = _valid_texture(ch, L, "grey")
    if ch.boolean(0.2):
        lab = _valid_texture(ch, L)
        if ch.boolean(0.5):
            kw["label"] = call("tx.Label", lab, uv_transform=call("tx.UVTransform", scale=(r3(ch.floats(0.5, 3)),
                                                                                         r3(ch.floats(0.5, 3))),
                                                                  offset=(r3(ch.floats(-1, 0)), r3(ch.floats(-1, 0)))))
        else:
            kw["label"] = call("tx.Label", lab)
    normal = ch.choice(["none", "none", "bump", "normal_map"])
    if normal == "bump":
        delta = ch.choice([None, "analytic", r3(ch.floats(0.001, 0.5))])
        height = Code(f"S * {r3(ch.floats(-0.05, 0.05))}")
        if "bump_extreme" in L.x:
            delta = ch.choice([delta, 1e-30, 1e-45, 0.5, 1e-7])
            height = ch.choice([height, Code(f"S * {ch.choice([1e3, 1e10, -1e10, 1e30])}"), 3e38, -3e38, 1e-45])
        kw["bump"] = call("tx.Bump", _valid_texture(ch, L, "grey"), height=height,
                          **({} if delta is None else {"delta": delta}))
    elif normal == "normal_map":
        kw["normal_map"] = call("tx.NormalMap", _valid_texture(ch, L, "normal"),
                                convention=ch.choice(["opengl", "directx"]), space=ch.choice(["tangent", "object"]))
    if kind in ("sphere", "cylinder", "quad") + (() if mapped else ("mesh",)) and ch.boolean(0.25):
        methods = ["tessellate"] + (["search", "maxmip"] if parallelogram or planar_convex or kind != "quad" else [])
        if kind == "mesh":                         # texray.compile.tessellate_mesh, .shells
            methods = ["tessellate", "search", "maxmip"]
        method = ch.choice(methods)
        hkind = ch.choice(["bricks_height", "noise"])
        htex = L.var("height", call("tx.Texture.procedural", hkind, size=ch.choice([8, 16, 32]),
                                    wrap=ch.choice(WRAPS)))
        d = {"scale": Code(f"S * {r3(ch.floats(0, 0.1))}"), "method": method}   # world units: S = the scene's scale
        if ch.boolean(0.3):
            d["offset"] = Code(f"S * {r3(ch.floats(0, 0.05))}")
        if method == "search":
            d.update(steps=ch.integer(1, 64), refine=ch.integer(0, 8), adaptive=ch.boolean(0.5))
        if method == "tessellate":
            d["resolution"] = ch.integer(1, 2)
        if "disp_extreme" in L.x:
            d["scale"] = ch.choice([Code(f"S * {ch.choice([1, 10, 1e3, 1e10])}"), 0.0, 1e-45, 1e18, 3e38])
            if method == "search":
                d.update(steps=ch.choice([1, 4096, d["steps"]]), refine=ch.choice([0, 32, d["refine"]]),
                         adaptive=ch.boolean(0.5))
            if ch.boolean(0.3):
                d["offset"] = ch.choice([Code("-S * 0.1"), Code("S * 1e6"), -1e18, 1e18])
        kw["displacement"] = call("tx.Displacement", htex, **d)
    return L.var("mat", call("tx.Material", **kw))


def gen_extreme_scene(ch) -> Case:
    """A random scene with some KNOBS turned to valid extremes (huge lights and colours, lights on
    surfaces, degenerate uvs and normals, extreme uv transforms, bumps, displacements...): a texray
    error is fine, non-finite pixels, crashes and hangs are not."""
    n = ch.integer(1, 3)
    knobs = frozenset(ch.choice(KNOBS) for _ in range(n))
    return gen_random_scene(ch, knobs)


def gen_random_scene(ch, knobs=frozenset()) -> Case:
    """A valid scene with every feature, at an extreme placement: must render finite pixels
    (or, where the placement is beyond float32's resolution of the objects, raise a texray error)."""
    import numpy as np
    L = _Lines()
    L.x = knobs
    if knobs:
        L.add(f"# extreme knobs: {', '.join(sorted(knobs))}")
    S = weighted(ch, [(3, 1.0), (2, 10 ** r3(ch.floats(-3, 3)))])                  # scale
    far = weighted(ch, [(3, 0.0), (2, 10 ** r3(ch.floats(4, 6)))])                 # distance from the origin
    d = unit_dir(ch)
    O = tuple(r3(far * x) for x in d)
    L.add(f"S, O = {lit(S)}, np.array({lit(O)})")
    baked = ch.boolean(0.5)      # coordinates computed in world space, else a tx.Transform per object
    objects = []
    n_obj = ch.integer(1, 5)
    floor = ch.boolean(0.6)
    grazing = floor and ch.boolean(0.3)

    def place(p):
        return Code(f"tuple(O + S * np.array({lit(tuple(p))}))")

    tf_world = Code("tx.Transform(translate=tuple(O), scale=S)")
    if floor:
        mat = _valid_material(ch, L, "quad", parallelogram=True)
        q = [(-3, 0, 3), (3, 0, 3), (3, 0, -3), (-3, 0, -3)]
        if baked:
            objects.append(L.var("obj", call("tx.Quad", *[place(p) for p in q], material=mat)))
        else:
            objects.append(L.var("obj", call("tx.Quad", *q, material=mat, transform=tf_world)))
    for _ in range(n_obj):
        kind = ch.choice(["sphere", "cylinder", "quad", "mesh", "mesh_file"])
        c = (r3(ch.floats(-1.5, 1.5)), r3(ch.floats(0, 1.5)), r3(ch.floats(-1.5, 1.5)))
        size = r3(ch.floats(0.2, 1.0))
        mapping = None
        if ch.boolean(0.2) or ("proj_extreme" in L.x and ch.boolean(0.6)):
            pk = {}
            if "proj_extreme" in L.x:
                pk = ch.choice([{"scale": 1e30}, {"scale": 1e-30}, {"origin": (1e17, 0, 0)}, {"scale": 3e38},
                                {"origin": c}, {"x_axis": (1, 1e-6, 0), "z_axis": (1, 0, 0)}])
            z = unit_dir(ch)
            x_axis = (1.0, 0.0, 0.0) if abs(z[0]) < 0.9 else (0.0, 1.0, 0.0)     # never parallel to z
            mapping = call("tx.Projection", ch.choice(["planar", "cylindrical", "spherical"]),
                           **{"z_axis": z, "x_axis": x_axis, "scale": r3(ch.floats(0.5, 4)), **pk})
        extra = {} if mapping is None else {"mapping": mapping}
        if kind == "sphere":
            mat = _valid_material(ch, L, "sphere")
            ax = {"axis_z": unit_dir(ch)} if ch.boolean(0.3) else {}
            if abs(ax.get("axis_z", (0.0,))[0]) > 0.9:     # the default axis_x (1, 0, 0) would be parallel
                ax["axis_x"] = (0.0, 1.0, 0.0)
            if baked:
                o = call("tx.Sphere", center=place(c), radius=Code(f"S * {size}"), material=mat, **ax, **extra)
            else:
                o = call("tx.Sphere", center=c, radius=size, material=mat, transform=tf_world, **ax, **extra)
        elif kind == "cylinder":
            mat = _valid_material(ch, L, "cylinder")
            t0 = r3(ch.floats(-180, 180))
            tr = (t0, r3(t0 + ch.floats(10, 360)))
            zr = (0.0, r3(ch.floats(0.2, 1.5)))
            if baked:
                o = call("tx.Cylinder", radius=Code(f"S * {size}"), z_range=Code(f"(0.0, S * {zr[1]})"),
                         theta_range=tr, origin=place(c), axis_z=(0, 1, 0), axis_x=(1, 0, 0), material=mat, **extra)
            else:
                o = call("tx.Cylinder", radius=size, z_range=zr, theta_range=tr, origin=c, axis_z=(0, 1, 0),
                         axis_x=(1, 0, 0), material=mat, transform=tf_world, **extra)
        elif kind == "quad":
            para = ch.boolean(0.5)
            trapezoid = not para and ch.boolean(0.5)      # planar and convex: search and maxmip displace it
            mat = _valid_material(ch, L, "quad", parallelogram=para, planar_convex=trapezoid)
            p0 = np.array(c)
            e0, e1 = np.array(vec3(ch, -1, 1)), np.array(vec3(ch, -1, 1))
            if np.linalg.norm(np.cross(e0, e1)) < 0.05:
                e0, e1 = np.array([size, 0, 0]), np.array([0, size, 0])
            p1 = np.array([r3(x) for x in p0 + e0])
            p3 = np.array([r3(x) for x in p0 + e1])
            p2 = p1 + p3 - p0                     # an exact parallelogram (to float64 rounding)
            if trapezoid:                         # p2 moved within the plane, the quad kept convex
                p2 = p2 + r3(ch.floats(-0.3, 0.3)) * (p1 - p0) + r3(ch.floats(-0.3, 0.3)) * (p3 - p0)
            elif not para:
                p2 = p2 + np.array(vec3(ch, -0.3, 0.3))
            p = [tuple(round(float(x), 9) for x in v) for v in (p0, p1, p2, p3)]
            uvs = {}
            if ch.boolean(0.3):
                uvs["uvs"] = [(r3(ch.floats(-1, 2)), r3(ch.floats(-1, 2))) for _ in range(4)]
            if "uv_degenerate" in L.x and ch.boolean(0.7):
                uvs["uvs"] = ch.choice([[(0.5, 0.5)] * 4, [(0, 0), (1, 0), (2, 0), (3, 0)], [(0, 0), (0, 1), (0, 1), (0, 0)],
                                        [(0, 0), (1e-30, 0), (1e-30, 1e-30), (0, 1e-30)],
                                        [(0, 0), (1e30, 0), (1e30, 1e30), (0, 1e30)], [(1e7, 1e7), (1e7 + 1, 1e7),
                                                                                      (1e7 + 1, 1e7 + 1), (1e7, 1e7 + 1)],
                                        [(0, 0), (1, 1), (0, 0), (1, 1)], [(3e38, 0), (-3e38, 0), (0, 3e38), (0, -3e38)]])
            if baked:
                o = call("tx.Quad", *[place(v) for v in p], material=mat, **uvs, **extra)
            else:
                o = call("tx.Quad", *p, material=mat, transform=tf_world, **uvs, **extra)
        elif kind == "mesh":
            mat = _valid_material(ch, L, "mesh", mapped=mapping is not None)
            gen = ch.choice(["uv_sphere", "torus", "grid", "vase"])
            args = {"uv_sphere": (ch.integer(3, 12), ch.integer(2, 8)), "torus": (ch.integer(3, 12), ch.integer(3, 8)),
                    "grid": (ch.integer(1, 4), ch.integer(1, 4)), "vase": (ch.integer(3, 12), ch.integer(3, 8))}[gen]
            m = L.var("m", call(f"procedural.{gen}", *args))
            smooth = ch.boolean(0.7)
            if "normals_odd" in L.x and ch.boolean(0.7):
                smooth = True
                L.add(f"{m}.normals = {ch.choice(['np.zeros_like(M.normals)', '-M.normals', 'M.normals * 1e-30', 'M.normals * 1e30', 'np.tile([[1.0, 0.0, 0.0]], (len(M.normals), 1))', 'M.normals[::-1].copy()']).replace('M', str(m))}")
            if "uv_degenerate" in L.x and ch.boolean(0.6):
                L.add(f"{m}.uvs = {ch.choice(['np.zeros_like(M.uvs)', 'M.uvs * 1e30', 'M.uvs * 1e-30', 'M.uvs + 1e7', 'M.uvs[:, :1].repeat(2, 1)', 'M.uvs * 3e38']).replace('M', str(m))}")
            rot = vec3(ch, -180, 180)
            if baked:
                o = call("tx.Mesh", Code(f"O + S * ({m}.positions * {size} + np.array({lit(c)}))"), Code(f"{m}.faces"),
                         uvs=Code(f"{m}.uvs"), normals=Code(f"{m}.normals") if smooth else None, material=mat, **extra)
            else:
                tf = call("tx.Transform", translate=Code(f"tuple(O + S * np.array({lit(c)}))"), rotate=rot,
                          scale=Code(f"S * {size}"))
                o = call("tx.Mesh", Code(f"{m}.positions"), Code(f"{m}.faces"), uvs=Code(f"{m}.uvs"),
                         normals=Code(f"{m}.normals") if smooth else None, material=mat, transform=tf, **extra)
        else:
            mat = _valid_material(ch, L, "mesh", mapped=mapping is not None)
            tf = call("tx.Transform", translate=Code(f"tuple(O + S * np.array({lit(c)}))"), rotate=vec3(ch, -180, 180),
                      scale=Code(f"S * {r3(size * ch.floats(0.3, 1.2))}"))
            o = call("tx.Mesh.load", Code(f"asset({ch.choice(OBJ_ASSETS)!r})"), material=mat, transform=tf,
                     **extra)
        v = L.var("obj", o)
        objects.append(v)
        if ch.boolean(0.1):                      # coincident copies
            for _ in range(ch.integer(1, 8)):
                objects.append(v)
    lights = []
    for _ in range(ch.integer(1, 3) if "many_lights" not in L.x else ch.choice([8, 16, 33, 64, 100])):
        pos = (r3(ch.floats(-4, 4)), r3(ch.floats(0.5, 6)), r3(ch.floats(-4, 4)))
        if "light_on_surface" in L.x and ch.boolean(0.6):
            pos = ch.choice([(r3(ch.floats(-2, 2)), 0.0, r3(ch.floats(-2, 2))), (0.0, 0.0, 0.0), (3.0, 0.0, 3.0),
                             (-3.0, 0.0, 3.0)])
        inten = Code(f"({r3(ch.floats(1, 60))} * S * S,) * 3")
        if "light_huge" in L.x and ch.boolean(0.7):
            inten = (ch.choice(HUGE),) * 3
        lights.append(call("tx.PointLight", Code(f"tuple(O + S * np.array({lit(pos)}))"), intensity=inten))
    if grazing:
        eye = (r3(ch.floats(-2, 2)), r3(10 ** ch.floats(-3, -1)), r3(ch.floats(2.5, 6)))
        look = (r3(ch.floats(-1, 1)), 0.0, r3(ch.floats(-3, 0)))
    else:
        dist = ch.floats(2.5, 8)
        dd = unit_dir(ch)
        dd = (dd[0], abs(dd[1]) * 0.8 + 0.05, dd[2])
        if math.hypot(dd[0], dd[2]) < 0.3:         # not straight down: up = +y must not be parallel
            dd = (dd[0] + 0.6, dd[1], dd[2] + 0.6)
        eye = tuple(r3(dist * x) for x in dd)
        look = (r3(ch.floats(-0.5, 0.5)), r3(ch.floats(0, 0.8)), r3(ch.floats(-0.5, 0.5)))
    fov = r3(ch.floats(10, 90))
    if "camera_extreme" in L.x:
        fov = ch.choice([fov, 1e-3, 1e-6, 179.0, 178.999])
        if ch.boolean(0.5):
            eye = ch.choice([(r3(ch.floats(-2, 2)), 0.0, r3(ch.floats(2, 5))), look, (0.0, 0.0, 0.0),
                             (0.0, 1e-7, 3.0)])
        if eye == look:
            look = (look[0], look[1] - 1.0, look[2] - 1.0)
    cam = call("tx.Camera", eye=Code(f"tuple(O + S * np.array({lit(eye)}))"),
               look_at=Code(f"tuple(O + S * np.array({lit(look)}))"), fov_y=fov)
    sc = {"camera": cam, "lights": lights, "objects": [Code(o) for o in objects]}
    if ch.boolean(0.5):
        sc["ambient"] = (r3(ch.floats(0, 0.2)),) * 3
    if ch.boolean(0.5):
        sc["background"] = (r3(ch.floats(0, 1)), r3(ch.floats(0, 1)), r3(ch.floats(0, 1)))
    if "ambient_huge" in L.x:
        sc["ambient"] = (ch.choice(HUGE),) * 3
    if "background_huge" in L.x:
        sc["background"] = (ch.choice(HUGE),) * 3
    L.var("scene", call("tx.Scene", **sc))
    kw = {"seed": ch.integer(0, 1000)}
    kw["specialize"] = weighted(ch, [(4, False), (1, True)])
    if ch.boolean(0.3):
        kw["aovs"] = tuple(a for a in AOV_NAMES if ch.boolean(0.4)) or ("depth",)
    if ch.boolean(0.1):
        kw["pipeline"] = "stages"
    if ch.boolean(0.1):
        kw["texture_filter"] = ch.choice(FILTERS)
    if ch.boolean(0.1):
        kw["jitter"] = False
    if ch.boolean(0.1):
        kw["shadows"] = False
    if ch.boolean(0.2):
        kw["light_sampling"] = "one"
    L.add(f"RESULT = {call('tx.render', Code('scene0'), ch.integer(4, 32), ch.integer(4, 32), ch.integer(1, 2), **kw)}")
    # Must render when float32 still resolves the objects (features of 0.2 S at distance far from
    # the origin, float32's relative step 1.2e-7); beyond that a clean SceneError is acceptable.
    resolvable = far == 0 or S >= far * 1e-5
    if knobs:
        huge = sorted(k for k in knobs if k.endswith("_huge"))
        return Case("extreme_scene", L.text(), tags=("huge colours: " + ", ".join(huge)) if huge
                    else ", ".join(sorted(knobs)))
    return Case("random_scene", L.text(), must_succeed=resolvable)


# =============================================================================
# Family: the API's geometry, camera, lights and scene constructors
# =============================================================================

_MESH_BASES = {
    "tri": "P = np.array([[-1.0, 0, 0], [1, 0, 0], [0, 1.5, 0]]); F = np.array([[0, 1, 2]]); "
           "UV = np.array([[0.0, 0], [1, 0], [0.5, 1]]); N = np.array([[0.0, 0, 1]] * 3)",
    "uv_sphere": "m = procedural.uv_sphere(8, 5); P, F, UV, N = m.positions.copy(), m.faces.copy(), m.uvs.copy(), "
                 "m.normals.copy()",
    "torus": "m = procedural.torus(8, 4); P, F, UV, N = m.positions.copy(), m.faces.copy(), m.uvs.copy(), "
             "m.normals.copy()",
    "grid": "m = procedural.grid(2, 2); P, F, UV, N = m.positions.copy(), m.faces.copy(), m.uvs.copy(), "
            "m.normals.copy()",
}

_MESH_VALUE_EDITS = [   # (code, must_reject reason or None)
    ("P[{i}] = (nan, 0, 0)", "a NaN vertex"),
    ("P[{i}] = (0, inf, 0)", "an infinite vertex"),
    ("P[{i}] = (1e39, 0, 0)", None),
    ("P[{i}] = (1e308, -1e308, 1e308)", None),
    ("P[{i}] = P[{j}]", None),
    ("P[:] = P[0]", None),
    ("P = P * 1e-30", None),
    ("P = P * 1e30", None),
    ("P = P * 1e18", None),
    ("P = P + 1e7", None),
    ("P = P * 1e-3 + 1e5", None),
    ("P = P + np.array([1e30, 0, 0])", None),
    ("P[:, 1] = 0", None),
    ("F[0, 0] = len(P)", "a face index beyond the vertex count"),
    ("F[0, 1] = -1", "a negative face index"),
    ("F[0, 2] = 2**40", "a face index beyond the vertex count"),
    ("F[:, 1] = F[:, 0]", None),
    ("F[:] = F[0]", None),
    ("F = F[::-1, ::-1].copy()", None),
    ("UV[{i}] = (nan, 0)", "a NaN uv"),
    ("UV = UV * 1e30", None),
    ("UV = UV * 1e39", None),
    ("UV[:] = 0.5", None),
    ("UV = UV + 1e6", None),
    ("N[:] = 0", None),
    ("N[{i}] = (nan, 0, 0)", "a NaN normal"),
    ("N = N * 1e39", None),
    ("N = -N", None),
    ("N = N * 1e-40", None),
]
# Edits that overwrite values an earlier edit made bad (P[:, 1] = 0 removes an inf in y; P[:] = P[0]
# copies row 0 over the others): they void that array's earlier reasons.
_OVERWRITING_EDITS = ("P[:, 1] = 0", "P[:] = P[0]", "UV[:] = 0.5", "N[:] = 0")


def _edited(whys, edit, why):
    """The (array, reason) list after ``edit``: one that replaces an array with None, or
    overwrites its values (_OVERWRITING_EDITS), voids the reasons of that array's earlier
    edits."""
    if edit.endswith(" = None") or edit in _OVERWRITING_EDITS:
        whys = [(a, w) for a, w in whys if a != edit[0]]
    return whys + [(edit[0], why)]


_MESH_TYPE_EDITS = [    # applied last, at most one
    ("P = P[:, :2]", "positions of shape (V, 2)"),
    ("P = P.tolist(); P[0] = P[0][:2]", "ragged positions"),
    ("P = P.astype(str)", "positions as strings"),
    ("P = P.astype(np.float16)", None),
    ("P = P.astype(np.float32)", None),
    ("P = P.astype(object)", None),
    ("P = P.ravel()", "1-D positions"),
    ("P = P[None]", "3-D positions"),
    ("P = []", "no vertices"),
    ("P = None", "positions None"),
    ("P = P.tolist()", None),
    ("F = F.astype(np.float64)", "float faces"),
    ("F = F.astype(np.float64) + 0.5", "fractional faces"),
    ("F = F.astype(np.uint64)", None),
    ("F = F.astype(np.int8)", None),
    ("F = F.astype(np.uint32)", None),
    ("F = F.astype(bool)", "boolean faces"),
    ("F = F[:, :2]", "faces of shape (F, 2)"),
    ("F = F[:0]", "no faces"),
    ("F = F.tolist(); F[0] = F[0][:2]", "ragged faces"),
    ("F = F.tolist()", None),
    ("F = 'abc'", "faces as a string"),
    ("UV = UV[:-1]", "fewer uvs than vertices"),
    ("UV = UV[:, :1]", "uvs of shape (V, 1)"),
    ("UV = UV.tolist(); UV[0] = [0]", "ragged uvs"),
    ("UV = None", None),
    ("N = N[:, :2]", "normals of shape (V, 2)"),
    ("N = N.tolist(); N[0] = [0]", "ragged normals"),
    ("N = None", None),
]

_OBJ_V = ["v -1 0 0", "v 1 0 0", "v 0 1.5 0", "v 0 0 1"]
_OBJ_BAD_V = ["v nan 0 0", "v inf 0 0", "v 1e39 0 0", "v 1e308 1e308 1e308", "v 1e999 0 0", "v abc 0 0", "v 1 2",
              "v 1 2 3 1 0 0", "v 1e-45 0 0", "v", "v 1e18 0 0"]
_OBJ_F = ["f 1 2 3", "f 1/1 2/2 3/3", "f 1//1 2//2 3//3", "f 1/1/1 2/2/2 3/3/3", "f -1 -2 -3", "f 1 2 3 4"]
_OBJ_BAD_F = ["f 1 2 99", "f 0 1 2", "f 1 2", "f 1 2 3 4 5", "f 1/9 2/9 3/9", "f a b c", "f 1 1 1", "f -9 1 2",
              "f 1//9 2//9 3//9", "f 99999999999999999999 1 2", "f 1.5 2 3", "f 1 2 3 4 1 2 3 4"]
_OBJ_OTHER = ["vt 0 0", "vt 1 0", "vt nan 0", "vn 0 0 1", "vn 0 0 0", "vn nan 0 0", "o part", "g group",
              "usemtl missing", "mtllib missing.mtl", "s 1", "xyz 1 2", "l 1 2", "p 1", "# comment", "",
              "vt 0 0 0 0", "vp 0 0", "cstype bezier"]
_MESH_FILE_KINDS = ["obj_text", "obj_text", "obj_text", "random", "truncated", "non_utf8_obj", "ply_text", "off_text",
                    "stl_text", "gltf_text", "empty", "directory", "missing", "fifo", "long_name", "png_as_obj",
                    "unknown_ext", "dev_zero", "null_byte"]


def _mesh_file_expr(ch, L):
    """(path expression, must_reject reason) of a mesh file for tx.Mesh.load."""
    k = ch.choice(_MESH_FILE_KINDS)
    if k == "obj_text":
        lines = list(_OBJ_V[:ch.integer(3, 4)])
        for _ in range(ch.integer(0, 3)):
            lines.insert(ch.integer(0, len(lines)), ch.choice(_OBJ_OTHER))
        if ch.boolean(0.4):
            lines[ch.integer(0, 2)] = ch.choice(_OBJ_BAD_V)
        lines.append(ch.choice(_OBJ_F))
        if ch.boolean(0.5):
            lines.append(ch.choice(_OBJ_BAD_F))
        if ch.boolean(0.1):
            lines = [ln for ln in lines if not ln.startswith("f")]
        return Code(f"write_text('m.obj', {lit(chr(10).join(lines) + chr(10))})"), None
    ext = ch.choice([".obj", ".ply", ".stl", ".off", ".glb", ".gltf"])
    if k == "random":
        return Code(f"random_bytes('m{ext}', {ch.integer(0, 3000)}, seed={ch.integer(0, 999)})"), "random bytes"
    if k == "truncated":
        return Code(f"truncated('m.obj', {ch.choice(OBJ_ASSETS)!r}, {r3(ch.floats(0, 0.99))})"), None
    if k == "non_utf8_obj":
        return Code("write_bytes('m.obj', b'v 0 0 0\\nv 1 0 0\\nv 0 1 0\\n# \\xff\\xfe\\xe9\\nf 1 2 3\\n')"), None
    if k == "ply_text":
        n = ch.choice([3, 0, 5, -1, 99])
        body = "ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n" \
               "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 %s\n" \
               % (n, ch.choice(["2", "7", "-1", "x"]))
        return Code(f"write_text('m.ply', {body!r})"), None
    if k == "off_text":
        body = ch.choice(["OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n",
                          "OFF\n9 9 0\n0 0 0\n", "OFF\n-1 -1 0\n", "OFF\n3 1 0\nnan 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"])
        return Code(f"write_text('m.off', {body!r})"), None
    if k == "stl_text":
        body = ch.choice(["solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\n"
                          "endfacet\nendsolid x\n", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nendloop\n"
                          "endfacet\nendsolid x\n", "solid\n", "solid x\nfacet normal 0 0 1\nouter loop\nvertex nan 0 0\n"
                          "vertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid x\n"])
        return Code(f"write_text('m.stl', {body!r})"), None
    if k == "gltf_text":
        body = ch.choice(["{}", '{"asset": {"version": "2.0"}, "buffers": [{"uri": "missing.bin", "byteLength": 36}]}',
                          "[1, 2", '{"asset": {"version": "2.0"}, "meshes": [{"primitives": [{"attributes": '
                          '{"POSITION": 0}}]}], "accessors": [{"count": 3, "type": "VEC3", "componentType": 5126}]}'])
        return Code(f"write_text('m.gltf', {body!r})"), "a broken glTF file"
    if k == "empty":
        return Code(f"random_bytes('m{ext}', 0, seed=0)"), "an empty mesh file"
    if k == "directory":
        return Code(f"directory('m{ext}')"), "a directory"
    if k == "missing":
        return Code(f"tmp('missing{ext}')"), "a missing file"
    if k == "fifo":
        return Code(f"fifo('m{ext}')"), "a FIFO"
    if k == "long_name":
        return Code(f"tmp('{'m' * ch.integer(250, 300)}{ext}')"), "a file name > 255 bytes"
    if k == "png_as_obj":
        return Code("copy_asset('m.obj', 'textures/checker.png')"), "a PNG named .obj"
    if k == "unknown_ext":
        return Code("copy_asset('m.xyz', 'meshes/torus.obj')"), "an unknown mesh extension"
    if k == "dev_zero":
        return Code("'/dev/zero'"), "/dev/zero"
    return Code(f"tmp('a\\x00b{ext}')"), "a path with a NUL byte"


_Z_RANGES = [(0.0, 1.0), (1.0, 0.0), (0.0, 0.0), ("a", "b"), (0, 1, 2), (nan, 1), (-1e308, 1e308), (0, 1e39),
             [0], None, "ab", (0, inf), (1e-45, 2e-45), ((0, 1), 2), (-1e18, 1e18)]
_THETA_RANGES = [(0, 360), (0, 361), (-720, -360), (0, 1e-9), (10, 10), (360, 0), (nan, 10), ("a", "b"),
                 (0, 1e308), [5], (-1e18, -1e18 + 360)]
_QUAD_UVS = [[[0, 0], [1, 0], [1], [0, 1]], [(0, 0)] * 3, [(0, 0)] * 4, [(nan, 0), (1, 0), (1, 1), (0, 1)],
             [(1e39, 0), (1, 0), (1, 1), (0, 1)], [(0, 0), (1e30, 0), (1e30, 1e30), (0, 1e30)], "abcd",
             [("a", "b")] * 4, [(0, 0, 0)] * 4, None, [(0, 0), (1, 0), (1, 1), (0, 1), (0, 0)],
             [(0, 0), (1e-30, 0), (1e-30, 1e-30), (0, 1e-30)]]
_FOVS = [1e-45, 1e-9, 0.001, 90, 179, 179.9, 180, 0, -1, nan, inf, 1e39, "40", True, None, 2**63]


def _simple_material(ch, textured=False):
    if textured:
        return call("tx.Material", diffuse=call("tx.Texture.procedural", "checker", size=16))
    return call("tx.Material", diffuse=(r3(ch.floats(0, 1)), r3(ch.floats(0, 1)), r3(ch.floats(0, 1))),
                specular=r3(ch.floats(0, 0.5)))


def _maybe_transform(ch, p=0.3):
    if not ch.boolean(p):
        return None
    kw = {}
    if ch.boolean(0.5):
        kw["translate"] = maybe_bad_vec(ch, vec3(ch, -1, 1), 0.4)
    if ch.boolean(0.5):
        kw["rotate"] = maybe_bad_vec(ch, vec3(ch, -180, 180), 0.3)
    if ch.boolean(0.5):
        kw["scale"] = ch.choice([1.0, 2.0, 0.5, 1e-3, 1e3, 0, -1, 1e-300, 1e308, 1e18, 1e-18, nan, (1, 2, 3),
                                 (1, 0, 1), (-1, 1, 1), "abc", None, [1, 2], 1e39])
    return call("tx.Transform", **kw)


# Attribute changes after construction (the dataclasses are mutable; render must check again):
# (target kinds, statement, must_reject reason or None).
_POST_EDITS = [
    ("mesh", "obj0.positions[0] = (nan, 0, 0)", "a NaN vertex set after construction"),
    ("mesh", "obj0.positions[0] = (1e39, 0, 0)", None),
    ("mesh", "obj0.faces[0, 0] = 10**6", "a face index beyond the vertex count set after construction"),
    ("mesh", "obj0.faces[0, 0] = -1", "a negative face index set after construction"),
    ("mesh", "obj0.faces = obj0.faces.astype(np.float64)", None),
    ("mesh", "obj0.positions = obj0.positions[:2]", "fewer vertices than the faces index"),
    ("mesh", "obj0.uvs = obj0.uvs[:1]", "uvs of the wrong length set after construction"),
    ("mesh", "obj0.normals = np.full_like(obj0.positions, nan)", "NaN normals set after construction"),
    ("mesh", "obj0.uvs = None", None),
    ("mesh", "obj0.positions = 'abc'", "positions replaced by a string"),
    ("sphere", "obj0.radius = -1", "a negative radius set after construction"),
    ("sphere", "obj0.radius = nan", "a NaN radius set after construction"),
    ("sphere", "obj0.center = 'abc'", "a string centre set after construction"),
    ("sphere", "obj0.axis_z = (0, 0, 0)", "a zero axis set after construction"),
    ("any", "obj0.material.tint = (1e39,) * 3", "a tint beyond float32 set after construction"),
    ("any", "obj0.material.diffuse = 'abc'", "a string diffuse set after construction"),
    ("any", "obj0.material.specular = -1", "a negative specular set after construction"),
    ("any", "obj0.material.shininess = nan", "a NaN shininess set after construction"),
    ("any", "obj0.material.bump = 1", "a bump that is not a Bump"),
    ("any", "obj0.material = 'abc'", "a material that is not a Material"),
    ("any", "obj0.transform = tx.Transform(scale=0)", "a zero scale set after construction"),
    ("any", "obj0.mapping = 'abc'", "a mapping that is not a Projection"),
    ("any", "obj0.material.diffuse.filter = 'abc'", None),
    ("any", "obj0.material.diffuse.wrap = 'abc'", None),
    ("any", "obj0.material.diffuse.max_aniso = 0", None),
    ("any", "obj0.material.diffuse.uv_transform = 'abc'", None),
    ("scene", "scene0.camera.up = (0, 0, 0)", "camera up = (0, 0, 0) set after construction"),
    ("scene", "scene0.camera.fov_y = 0", "fov_y = 0 set after construction"),
    ("scene", "scene0.camera.eye = scene0.camera.look_at", "eye = look_at set after construction"),
    ("scene", "scene0.lights[0].intensity = -1", "a negative intensity set after construction"),
    ("scene", "scene0.lights[0].position = (1e39,) * 3", "a light position beyond float32 set after construction"),
    ("scene", "scene0.ambient = (nan,) * 3", "a NaN ambient set after construction"),
    ("scene", "scene0.background = (1e39,) * 3", "a background beyond float32 set after construction"),
    ("scene", "scene0.objects.append('x')", "a string among the objects"),
    ("scene", "scene0.lights.append(None)", "None among the lights"),
    ("scene", "scene0.objects = None", "objects = None"),
]


def gen_mutated(ch, L, objs):
    """Post-construction edits of a valid object obj0 / scene0; returns must_reject."""
    kind = "mesh" if "tx.Mesh(" in L.text() else "sphere" if "tx.Sphere(" in L.text() else "other"
    textured = "Texture." in L.text()
    edits = [e for e in _POST_EDITS if e[0] in (kind, "any", "scene")
             and (textured or ".diffuse." not in e[1])]
    reject = None
    chosen = [ch.choice(edits) for _ in range(ch.integer(1, 2))]
    # An edit that replaces an object by a non-object goes last (and alone of its kind), so that
    # the other edit can still reach through it.
    replaces = [e for e in chosen if re.search(r"= ('abc'|None|1)$", e[1]) or "obj0.material = " in e[1]]
    chosen = [e for e in chosen if e not in replaces] + replaces[:1]
    root = lambda e: re.split(r"[\[ =]", e[1])[0]          # noqa: E731  (obj0.faces[0, 0] = ... -> obj0.faces)
    chosen = [e for i, e in enumerate(chosen) if not any(root(f) == root(e) for f in chosen[i + 1:])]
    for target, stmt, why in chosen:
        L.add(stmt)
        reject = reject or why
    return reject


def gen_post_edit(ch) -> Case:
    """A valid mesh / sphere / quad scene whose objects are changed after construction."""
    L = _Lines()
    kind = ch.choice(["mesh", "sphere", "quad"])
    mat = _simple_material(ch, ch.boolean(0.4))
    if kind == "mesh":
        L.add("m = procedural.uv_sphere(8, 5)")
        L.var("obj", call("tx.Mesh", Code("m.positions.copy()"), Code("m.faces.copy()"), uvs=Code("m.uvs.copy()"),
                          normals=Code("m.normals.copy()") if ch.boolean(0.7) else None, material=mat))
    elif kind == "sphere":
        L.var("obj", call("tx.Sphere", radius=0.8, material=mat))
    else:
        L.var("obj", call("tx.Quad", (-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0), material=mat))
    L.var("scene", call("tx.Scene", camera=call("tx.Camera", eye=(0.3, 0.5, 4)),
                        lights=[call("tx.PointLight", (1, 3, 2), intensity=(20, 20, 20))], objects=[Code("obj0")]))
    reject = gen_mutated(ch, L, None)
    L.add(f"RESULT = {call('tx.render', Code('scene0'), ch.integer(4, 24), ch.integer(4, 24), ch.integer(1, 2), specialize=weighted(ch, [(4, False), (1, True)]))}")
    return Case("post_edit", L.text(), must_reject=reject)


def gen_geometry(ch) -> Case:
    L = _Lines()
    kind = ch.choice(["mesh", "sphere", "cylinder", "quad", "camera", "light", "transform", "scene", "far",
                              "mesh_file"])
    reject = None
    objs = []
    textured = ch.boolean(0.3)
    mat = _simple_material(ch, textured)
    if kind == "mesh":
        base = ch.choice(list(_MESH_BASES))
        L.add(_MESH_BASES[base])
        whys = []                                  # (array edited, reason)
        for _ in range(ch.integer(0, 3)):
            edit, why = ch.choice(_MESH_VALUE_EDITS)
            L.add(edit.format(i=ch.integer(0, 2), j=ch.integer(0, 2)))
            whys = _edited(whys, edit, why)
        if ch.boolean(0.5):
            edit, why = ch.choice(_MESH_TYPE_EDITS)
            L.add(edit)
            whys = _edited(whys, edit, why)
        kw = {}
        if ch.boolean(0.7):
            kw["uvs"] = Code("UV")
        if ch.boolean(0.6):
            kw["normals"] = Code("N")
        used = {"P", "F"} | ({"U"} if "uvs" in kw else set()) | ({"N"} if "normals" in kw else set())
        reject = next((w for a, w in whys if w and a in used), None)
        if textured and ("uvs" not in kw or any(e.startswith("UV = None") for e in L.lines)):
            reject = reject or "a textured mesh without uvs"
        objs.append(L.var("obj", call("tx.Mesh", Code("P"), Code("F"), material=mat, transform=_maybe_transform(ch),
                                      **kw)))
    elif kind == "mesh_file":
        path, reject = _mesh_file_expr(ch, L)
        objs.append(L.var("obj", call("tx.Mesh.load", path, material=mat, transform=_maybe_transform(ch, 0.2))))
    elif kind == "sphere":
        r = maybe_bad_num(ch, r3(ch.floats(0.2, 1.5)), 0.25)
        if _is_num(r) and r <= 0:
            reject = "a radius <= 0"
        kw = {"center": maybe_bad_vec(ch, vec3(ch, -0.5, 0.5), 0.2), "radius": r}
        if ch.boolean(0.4):
            kw["axis_z"] = maybe_bad_vec(ch, unit_dir(ch), 0.3)
        if ch.boolean(0.4):
            kw["axis_x"] = maybe_bad_vec(ch, unit_dir(ch), 0.3)
        objs.append(L.var("obj", call("tx.Sphere", material=mat, transform=_maybe_transform(ch), **kw)))
    elif kind == "cylinder":
        kw = {"radius": maybe_bad_num(ch, r3(ch.floats(0.2, 1.0)), 0.3)}
        if _is_num(kw["radius"]) and kw["radius"] <= 0:
            reject = "a radius <= 0"
        if ch.boolean(0.6):
            kw["z_range"] = ch.choice(_Z_RANGES) if ch.boolean(0.5) else (r3(ch.floats(-1, 0)), r3(ch.floats(0.01, 1)))
        if ch.boolean(0.4):
            if ch.boolean(0.5):
                kw["theta_range"] = ch.choice(_THETA_RANGES)
            else:
                t0 = r3(ch.floats(-400, 400))
                kw["theta_range"] = (t0, r3(t0 + ch.floats(1, 360)))
        if ch.boolean(0.3):
            kw["origin"] = maybe_bad_vec(ch, vec3(ch, -0.5, 0.5), 0.4)
        if ch.boolean(0.4):
            kw["axis_z"] = maybe_bad_vec(ch, unit_dir(ch), 0.5)
        if ch.boolean(0.3):
            kw["axis_x"] = maybe_bad_vec(ch, unit_dir(ch), 0.5)
        objs.append(L.var("obj", call("tx.Cylinder", material=mat, transform=_maybe_transform(ch), **kw)))
    elif kind == "quad":
        shape = ch.choice(["square", "random", "random", "collinear", "coincident", "triangle", "twisted", "huge",
                           "tiny", "bad", "near_collinear"])
        p = {"square": [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)],
             "collinear": [(-1, 0, 0), (0, 0, 0), (1, 0, 0), (2, 0, 0)],
             "coincident": [(0, 0, 0)] * 4,
             "triangle": [(-1, -1, 0), (1, -1, 0), (0, 1, 0), (0, 1, 0)],
             "twisted": [(-1, -1, 0), (1, -1, 0), (-1, 1, 0), (1, 1, 0)],
             "huge": [(-1e30, -1e30, 0), (1e30, -1e30, 0), (1e30, 1e30, 0), (-1e30, 1e30, 0)],
             "tiny": [(-1e-30, -1e-30, 0), (1e-30, -1e-30, 0), (1e-30, 1e-30, 0), (-1e-30, 1e-30, 0)],
             "random": [vec3(ch, -1.5, 1.5) for _ in range(4)],
             "near_collinear": [(-1, 0, 0), (0, 1e-12, 0), (1, 0, 0), (2, 1e-12, 1e-12)],
             "bad": [maybe_bad_vec(ch, vec3(ch, -1, 1), 0.8) for _ in range(4)]}[shape]
        kw = {}
        if ch.boolean(0.4):
            kw["uvs"] = ch.choice(_QUAD_UVS)
        tf = _maybe_transform(ch)
        if shape in ("collinear", "coincident") and tf is None:     # (a rotation may round it to non-zero)
            reject = "a quad of zero area"
        objs.append(L.var("obj", call("tx.Quad", *p, material=mat, transform=tf, **kw)))
    elif kind == "far":        # a valid object far from the origin / at an extreme scale
        s = ch.choice([1e-30, 1e-12, 1e-6, 1e-3, 1e3, 1e6, 1e12, 1e17])
        o = ch.choice([0.0, 1e5, 1e10, 1e15, 1e17, -1e17, 1e20, 1e30])
        L.add(f"S, O = {lit(s)}, np.array([{lit(o)}, {lit(o / 2)}, 0.0])")
        shape = ch.choice(["sphere", "cylinder", "quad", "mesh"])
        if shape == "sphere":
            objs.append(L.var("obj", call("tx.Sphere", center=Code("tuple(O)"), radius=Code("S"), material=mat)))
        elif shape == "cylinder":
            objs.append(L.var("obj", call("tx.Cylinder", radius=Code("S"), z_range=Code("(-S, S)"),
                                          origin=Code("tuple(O)"), axis_z=(0, 1, 0), material=mat)))
        elif shape == "quad":
            objs.append(L.var("obj", call("tx.Quad", *[Code(f"tuple(O + S * np.array({lit(c)}))") for c in
                                                       [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]],
                                          material=mat)))
        else:
            L.add("m = procedural.uv_sphere(8, 5)")
            objs.append(L.var("obj", call("tx.Mesh", Code("O + S * m.positions"), Code("m.faces"), uvs=Code("m.uvs"),
                                          normals=Code("m.normals"), material=mat)))
        L.var("cam", call("tx.Camera", eye=Code("tuple(O + S * np.array([0.3, 0.5, 4.0]))"),
                          look_at=Code("tuple(O)"), fov_y=40))
        L.var("light", call("tx.PointLight", Code("tuple(O + S * np.array([2.0, 3.0, 4.0]))"),
                            intensity=Code("(min(20 * S * S, 1e38),) * 3")))
    else:
        objs.append(L.var("obj", call("tx.Sphere", radius=0.8, material=mat)))
    n_copies = ch.integer(0, 8) if ch.boolean(0.2) else 0
    if kind == "light" and ch.boolean(0.5):      # a light over coincident quads
        q = L.var("quad", call("tx.Quad", (-2, -1, 2), (2, -1, 2), (2, -1, -2), (-2, -1, -2), material=mat))
        objs.append(q)
        n_copies = ch.integer(1, 8)
    objs += [objs[-1]] * n_copies
    # camera
    if kind == "camera":
        kw = {}
        for key, good in (("eye", (0, 1, 4)), ("look_at", (0, 0, 0)), ("up", (0, 1, 0))):
            if ch.boolean(0.5):
                kw[key] = ch.choice(BAD_VEC3 + [(0, 1e-300, 0), (0, 4, 0), (0, 1, 4), (1e308, 1e308, 1e308),
                                                (-1e308, 0, 0), (0, -1, 0), (1e-9, 1, 4)])
        if ch.boolean(0.4):
            kw["fov_y"] = ch.choice(_FOVS)
        for key in ("eye", "look_at", "up"):
            v = kw.get(key)
            if v is not None and isinstance(v, (tuple, list)) and _non_finite_or_huge(v, 1.7e308):
                reject = reject or f"a non-finite camera {key}"
        if kw.get("up") == (0, 0, 0):
            reject = reject or "camera up = (0, 0, 0)"
        f = kw.get("fov_y")
        if _is_num(f) and (f <= 0 or f >= 180 or not math.isfinite(f)):
            reject = reject or f"fov_y = {f!r}"
        cam = L.var("cam", call("tx.Camera", **kw))
    elif kind != "far":
        cam = L.var("cam", call("tx.Camera", eye=(r3(ch.floats(-1, 1)), r3(ch.floats(0, 2)), 4.0)))
    else:
        cam = Code("cam0")
    # lights
    lights = []
    if kind == "light":
        for _ in range(ch.integer(1, 3)):
            pos = ch.choice([(1, 3, 2), (1e39, 1e39, 1e39), (1e39, 0, 0), (1e18, 1e18, 1e18), (0, 1e38, 0),
                             (1e-45, 0, 0), (0, 0, 0), (0, -1, 0), (nan, 0, 0), (inf, 0, 0), (1e308, 0, 0),
                             [1, 2], "abc", None, (1e19, 0, 0)])
            inten = ch.choice([(10, 10, 10), (1e39, 1e39, 1e39), -1, (-1, 0, 0), (nan, 1, 1), 1e38, 0, 1e-45,
                               (inf, 0, 0), 1e39, [1, 2], "abc", None, 3e38, (1e30,) * 3])
            if _has_negative(inten):
                reject = reject or "a negative light intensity"
            if _non_finite_or_huge(inten):
                reject = reject or "a non-finite (float32) light intensity"
            if isinstance(pos, tuple) and any(isinstance(x, float) and not math.isfinite(x) for x in pos):
                reject = reject or "a non-finite light position"
            lights.append(call("tx.PointLight", pos, intensity=inten))
    elif kind == "far":
        lights.append(Code("light0"))
    else:
        lights.append(call("tx.PointLight", (1, 3, 2), intensity=(20, 20, 20)))
    sc = {"camera": cam, "lights": lights, "objects": [Code(o) for o in objs]}
    if kind == "scene":
        what = ch.choice(["lights", "camera", "objects", "ambient", "background"])
        sc[what] = {"lights": ch.choice([None, [1], "abc", (Code("tx.PointLight((1, 3, 2))"),), [None], {}]),
                    "camera": ch.choice([None, "cam", 1, Code("tx.Camera(up=(0, 0, 0))")]),
                    "objects": ch.choice([["x"], None, [None], "abc", [Code("tx.Camera()")], (Code(objs[0]),),
                                          [[Code(objs[0])]]]),
                    "ambient": ch.choice(BAD_VEC3 + [(-1, 0, 0)]),
                    "background": ch.choice(BAD_VEC3 + [(-1, 0, 0)])}[what]
    elif kind == "light" and ch.boolean(0.4):
        key = ch.choice(["ambient", "background"])
        sc[key] = v = ch.choice([(1e39,) * 3, (1e38,) * 3, (-1, 0, 0), (nan, 0, 0), (0.1, 0.1, 0.1), 1e39])
        if _has_negative(v) or _non_finite_or_huge(v):
            reject = reject or f"{key} = {v!r}"
    L.var("scene", call("tx.Scene", **sc))
    if kind == "scene" and ch.boolean(0.5):
        L.add(f"scene0.add({lit(ch.choice(['x', None, 1, Code('tx.Camera()'), Code('obj0')]))})")
    L.add(f"RESULT = {call('tx.render', Code('scene0'), ch.integer(4, 24), ch.integer(4, 24), ch.integer(1, 2), specialize=weighted(ch, [(4, False), (1, True)]))}")
    return Case("geometry", L.text(), must_reject=reject)


# =============================================================================
# Family: textures and material roles
# =============================================================================

_DTYPES = ["float32", "float64", "float16", "uint8", "uint16", "int64", "int32", "int8", "bool", "object",
           "complex64", "str"]
_SHAPES = [(4, 4, 3), (4, 4), (4, 4, 1), (4, 4, 2), (4, 4, 4), (1, 1), (1, 1, 3), (0, 0), (0, 4, 3), (4,), (4, 4, 5),
           (2, 3, 4, 1), (), (1, 256, 3), (3, 1, 4)]
_VALUES = [0.5, 0, 1, -1, 2**40, 65504, 65520, 1e5, 1e39, nan, inf, -inf, 1e-45, 255, 65535, 2**63 - 1, -2**63]
_PROC_PARAMS = {
    "size": [16, (8, 16), 8, 1, -1, 0, 100000, 1e-9, 2.5, (0, 8), (8,), "a", 2**63, True, (8, 8, 8), (2**31, 1),
             1e308, nan, (-8, 8)],
    "seed": [0, 1, -1, 2**63, 2**64, 1.5, nan, "a"],
    "n_checks": [8, 0, -1, 1e9, (2, 0), (2, 3), 1.5, nan],
    "n_rows": [8, 0, -1, 1, 3, 1e6, 1.5], "n_cols": [4, 0, -1, 1e6, 2.5],
    "mortar": [0.12, 0, -1, 1e39, nan, 2], "bevel": [0.1, 0, -0.1, nan, 1e-300], "offset": [0.5, 0, -1, 1e308],
    "roughness": [0.08, 0, 10, nan], "variation": [0.25, 0, 100, nan],
    "n": [6, 0, -1, 1, 1e6], "grout": [0.06, 0, -1, nan],
    "octaves": [5, 0, -1, 1, 40, 64, 100, 2.5], "cells": [4, 0, -1, (0, 4), (2, 32), 1e9, 2.5, (4,)],
    "persistence": [0.5, 0, -1, nan, inf, 2],
    "n_rings": [18, 0, -1, 1e9, nan], "n_veins": [3, 0, -1, 1e9, nan], "sea_level": [0.52, 0, 1, -1, nan, 2],
    "c0": [(0.9, 0.9, 0.85), (1e39, 0, 0), (nan, 0, 0), (-1, 0, 0), (2, 2, 2), "abc"],
    "color": [(0.85, 0.12, 0.1), (1e39, 0, 0), (nan, 0, 0)], "light": [(0.8, 0.57, 0.34), (nan, 0, 0)],
    "foo": [1],
}
_PROC_KIND_PARAMS = {
    "checker": ["size", "n_checks", "c0"], "bricks": ["size", "n_rows", "n_cols", "mortar", "bevel", "seed", "offset",
                                                      "variation"],
    "bricks_height": ["size", "n_rows", "n_cols", "mortar", "bevel", "seed", "offset", "roughness"],
    "noise": ["size", "octaves", "seed", "cells", "persistence"], "wood": ["size", "seed", "n_rings", "light"],
    "marble": ["size", "seed", "n_veins"], "tiles": ["size", "n", "grout", "bevel", "seed"],
    "globe": ["size", "seed", "sea_level"], "label": ["size", "seed", "color"],
}
_BAD_FILES = ["random_png", "truncated_png", "directory", "none", "fifo", "dev_zero", "long_name", "deep_path",
              "missing", "obj_as_png", "empty", "nan_exr", "five_channels", "tiny", "null_byte", "int", "bytes",
              "big_values_exr", "neg_exr"]


def _bad_file_expr(ch, L, ext=".png"):
    """(path expression, must_reject reason or None) of a file for Texture.load."""
    k = weighted(ch, [(len(_BAD_FILES) // 2, "asset")] + [(1, b) for b in _BAD_FILES])
    if k == "asset":
        return Code(f"asset({ch.choice(PNG_ASSETS)!r})"), None
    seed = ch.integer(0, 999)
    e = {
        "random_png": (f"random_bytes('r{ext}', {ch.integer(0, 2000)}, seed={seed})", "random bytes"),
        "truncated_png": (f"truncated('t{ext}', {ch.choice(PNG_ASSETS)!r}, {r3(ch.floats(0, 0.99))})",
                          "a truncated file"),
        "directory": (f"directory('d{ext}')", "a directory"),
        "none": ("None", "None as a path"),
        "fifo": (f"fifo('f{ext}')", "a FIFO"),
        "dev_zero": ("'/dev/zero'", "/dev/zero"),
        "long_name": (f"tmp('{'a' * ch.integer(250, 300)}{ext}')", "a file name > 255 bytes"),
        "deep_path": (f"tmp('{'d' * 200 + '/'}' * 21 + 'x{ext}')", "a path > 4096 bytes"),
        "missing": (f"tmp('missing{ext}')", "a missing file"),
        "obj_as_png": (f"copy_asset('mesh{ext}', 'meshes/torus.obj')", "an OBJ file named .png"),
        "empty": (f"random_bytes('e{ext}', 0, seed=0)", "an empty file"),
        "nan_exr": ("write_image('n.exr', np.full((4, 4, 3), nan))", "NaN texels"),
        "five_channels": ("write_image('five.exr', np.full((4, 4, 5), 0.5))", "5 channels"),
        "tiny": ("write_image('one.png', np.full((1, 1, 3), 0.5), 'uint8')", None),
        "null_byte": (f"tmp('a\\x00b{ext}')", "a path with a NUL byte"),
        "int": ("7", "an int as a path"),
        "bytes": (f"b'/nonexistent{ext}'", "bytes as a path"),
        "big_values_exr": ("write_image('big.exr', np.full((4, 4, 3), 1e38))", None),
        "neg_exr": ("write_image('neg.exr', np.full((4, 4, 3), -1.0))", None),
    }[k]
    return Code(e[0]), e[1]


def _odd_texture(ch, L):
    """(texture variable, must_reject reason) of an odd texture."""
    src = ch.choice(["from_array", "procedural", "load"])
    reject = None
    opts = {}
    if ch.boolean(0.4):
        opts["filter"] = weighted(ch, [(3, f) for f in FILTERS] + [(1, x) for x in ("x", None, 1, "TRILINEAR")])
    if ch.boolean(0.3):
        opts["wrap"] = weighted(ch, [(3, w) for w in WRAPS] + [(1, x) for x in ("x", None, 0)])
    if ch.boolean(0.15):
        opts["uv_transform"] = ch.choice([
            call("tx.UVTransform", scale=(0, 1)), call("tx.UVTransform", scale=(1e39, 1)),
            call("tx.UVTransform", rotation=nan), call("tx.UVTransform", scale=(1e-30, 1e-30)),
            call("tx.UVTransform", offset=(1e30, 0)), call("tx.UVTransform", scale=(1e30, 1e30)),
            call("tx.UVTransform", rotation=1e308), "abc", call("tx.UVTransform", scale=(-1, 2), rotation=45)])
    if ch.boolean(0.1):
        opts["max_aniso"] = ch.choice([0, 1, 64, 65, True, 1.5, 2**63, -1, "16"])
    if src == "from_array":
        dtype = ch.choice(_DTYPES)
        shape = ch.choice(_SHAPES)
        value = ch.choice(_VALUES)
        how = ch.choice(["full", "random", "ramp"])
        if how == "full":
            arr = f"np.full({lit(shape)}, {lit(value)}).astype({dtype!r})" if dtype != "str" else \
                f"np.full({lit(shape)}, 'x')"
        elif how == "random":
            arr = f"(np.random.default_rng({ch.integer(0, 99)}).random({lit(shape)}) * {lit(value)}).astype({dtype!r})"
        else:
            arr = f"np.linspace(0, {lit(value)}, int(np.prod({lit(shape)}))).reshape({lit(shape)}).astype({dtype!r})"
        if dtype in ("float32", "float64", "float16", "int64", "object") and how == "full" and \
                len(shape) in (2, 3) and all(shape) and (len(shape) == 2 or shape[2] <= 4):
            if _is_num(value) and (not math.isfinite(value) or abs(value) > 65504):
                reject = f"texel value {value!r} ({dtype}) outside the half-float range"
        cs = weighted(ch, [(4, "linear"), (4, "srgb"), (1, "auto"), (1, "x")])
        expr = call("tx.Texture.from_array", Code(arr), colorspace=cs, **opts)
    elif src == "procedural":
        kind = weighted(ch, [(3, k) for k in _PROC_KIND_PARAMS] + [(1, "nonexistent"), (1, ""), (1, "Checker")])
        params = {}
        names = _PROC_KIND_PARAMS.get(kind, ["size"]) + (["foo"] if ch.boolean(0.1) else [])
        params["size"] = ch.choice(_PROC_PARAMS["size"][:3]) if not ch.boolean(0.35) else ch.choice(_PROC_PARAMS["size"])
        for name in names:
            if name != "size" and ch.boolean(0.3):
                params[name] = ch.choice(_PROC_PARAMS[name])
        sz = params["size"]
        if _is_num(sz) and sz < 1 or (isinstance(sz, tuple) and any(_is_num(x) and x < 1 for x in sz)):
            reject = f"size {sz!r}"
        for name in ("n_rows", "n_cols", "n", "n_checks"):
            if _is_num(params.get(name)) and params[name] <= 0:
                reject = reject or f"{name} = {params[name]!r}"
        expr = call("tx.Texture.procedural", kind, **opts, **params)
    else:
        path, reject = _bad_file_expr(ch, L)
        cs = weighted(ch, [(6, "auto"), (2, "linear"), (2, "srgb"), (1, "x"), (1, None)])
        expr = call("tx.Texture.load", path, colorspace=cs, **opts)
    return L.var("tex", expr), reject


def gen_texture(ch) -> Case:
    L = _Lines()
    tex, reject = _odd_texture(ch, L)
    role = ch.choice(["diffuse", "specular", "shininess_map", "label", "bump", "normal_map", "displacement",
                      "constants"])
    kw = {}
    if role in ("diffuse", "specular", "shininess_map"):
        kw[role] = tex
        if role == "shininess_map" and ch.boolean(0.5):
            kw["shininess"] = ch.choice([32, 0, 1e39, 1e30, -1, nan, 1e-45])
    elif role == "label":
        kw["label"] = call("tx.Label", tex, uv_transform=ch.choice([None, call("tx.UVTransform", scale=(2, 2)), "x"]))
    elif role == "bump":
        kw["bump"] = call("tx.Bump", tex, height=ch.choice([0.01, 0, -0.05, 1e39, 1e30, 3e38, nan, inf, 1e-45, "x"]),
                          delta=ch.choice([None, "analytic", 0.5, 0.6, 0, -1, 1e-45, nan, "x", 1e-30]))
    elif role == "normal_map":
        kw["normal_map"] = call("tx.NormalMap", tex, convention=ch.choice(["opengl", "directx", "x", None]),
                                space=ch.choice(["tangent", "object", "world", 1]))
    elif role == "displacement":
        kw["displacement"] = call(
            "tx.Displacement", tex, scale=ch.choice([0.1, 0, -0.1, 1e39, 1e30, 1e18, 3e38, nan, 1e-45, 100]),
            offset=ch.choice([0.0, 1e30, -1, -1e30, nan, 0.5]), method=ch.choice(["search", "maxmip", "tessellate", "x"]),
            steps=ch.choice([32, 1, 0, 4096, 4097, -1, 2**63, 1.5, True]), refine=ch.choice([8, 0, 32, 33, -1]),
            adaptive=ch.choice([False, True, 1, "yes"]), resolution=ch.choice([1, 2, 0, 17, -1]))
    else:                                       # the illumination constants, textured or not
        kw["diffuse"] = tex
        key = ch.choice(["tint", "specular", "shininess"])
        kw[key] = ch.choice([(1e39,) * 3, (1e38,) * 3, (3e38, 0, 0), 1e39, (nan, 0, 0), (-1, 0, 0), 1e30, 0, 1e-45,
                             (inf, 1, 1)])
        v = kw[key]
        if key in ("tint", "specular") and _has_negative(v):
            reject = reject or f"a negative {key}"
        if _non_finite_or_huge(v):
            reject = reject or f"{key} = {v!r}: not finite in float32"
    if ch.boolean(0.3) and role != "constants":
        key = ch.choice(["tint", "specular", "diffuse"])
        if key not in kw:
            kw[key] = ch.choice([(1e39,) * 3, (3e38, 3e38, 3e38), (1e20,) * 3, (0.5, 0.5, 0.5), -1, nan])
            if _has_negative(kw[key]):
                reject = reject or f"a negative {key}"
            if _non_finite_or_huge(kw[key]):
                reject = reject or f"{key} = {kw[key]!r}: not finite in float32"
    mat = L.var("mat", call("tx.Material", **kw))
    shape = ch.choice(["quad", "sphere", "cylinder", "mesh", "grazing_quad"])
    if shape in ("quad", "grazing_quad"):
        obj = call("tx.Quad", (-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0), material=mat)
    elif shape == "sphere":
        obj = call("tx.Sphere", radius=0.9, material=mat)
    elif shape == "cylinder":
        obj = call("tx.Cylinder", radius=0.7, z_range=(-0.8, 0.8), axis_z=(0, 1, 0), material=mat)
    else:
        L.add("m = procedural.uv_sphere(8, 5)")
        obj = call("tx.Mesh", Code("m.positions"), Code("m.faces"), uvs=Code("m.uvs"), normals=Code("m.normals"),
                   material=mat)
    o = L.var("obj", obj)
    eye = (0, 0.05, 3) if shape != "grazing_quad" else (0, -0.98, 0.5)
    L.var("scene", call("tx.Scene", camera=call("tx.Camera", eye=eye, look_at=(0, 0, 0) if shape != "grazing_quad" else (0, 1, 0)),
                        lights=[call("tx.PointLight", (1, 2, 3), intensity=(20, 20, 20))], objects=[o],
                        ambient=(0.05, 0.05, 0.05)))
    kwr = {"specialize": weighted(ch, [(4, False), (1, True)])}
    if ch.boolean(0.2):
        kwr["aovs"] = ("uv", "shading_normal", "dpdu", "object_id")
    if ch.boolean(0.15):
        kwr["texture_filter"] = ch.choice(FILTERS)
    L.add(f"RESULT = {call('tx.render', Code('scene0'), ch.integer(4, 24), ch.integer(4, 24), ch.integer(1, 2), **kwr)}")
    return Case("texture", L.text(), must_reject=reject)


# =============================================================================
# Family: render()'s arguments, devices, PYOPENCL_CTX
# =============================================================================

_BASE_SCENE = ("scene = tx.Scene(camera=tx.Camera(eye=(0, 1, 4)), lights=[tx.PointLight((1, 3, 2), intensity=(20, 20, 20))],\n"
               "                 objects=[tx.Sphere(radius=0.8, material=tx.Material(diffuse=tx.Texture.procedural('checker', size=16))),\n"
               "                          tx.Quad((-2, -0.8, 2), (2, -0.8, 2), (2, -0.8, -2), (-2, -0.8, -2))],\n"
               "                 background=(0.2, 0.3, 0.4))")
_SIZES = [16, 1, 7, 0, -1, 2**32, 2**63, 1.5, 16.0, True, "16", None, Code("np.int64(8)"), Code("np.uint8(8)"),
          2**31, -2**63, Code("np.float64(8)")]
_SPPS = [1, 2, 0, -1, 2**32, 2**63, 2**32 + 1, 1.5, True, "2", None, Code("np.int32(2)")]
_SEEDS = [0, 1, -1, 2**32, 2**63, 2**64, -2**63, 1.5, "0", None, True, Code("np.uint64(2**63)")]
_DEVICES = ["cpu", "", "abc", 7, -1, 0, 1.5, True, " cpu ", "CPU", "gpu", "portable", "pthread", 2**63,
            Code("tx.devices()[0]"), Code("b'cpu'")]
_CTX_ENVS = ["7", "abc", "0:5", "0", "0:0", ":", "0:", "-1", "", "1:0", "0:abc", "Portable"]


def gen_render_args(ch) -> Case:
    L = _Lines()
    L.add(_BASE_SCENE)
    env = {}
    reject = None
    sub = weighted(ch, [(5, "kwargs"), (1, "seed_pair"), (1, "env"), (1, "to_file")])
    w, h, spp = ch.integer(4, 16), ch.integer(4, 16), ch.integer(1, 2)
    kw = {"specialize": weighted(ch, [(4, False), (1, True)])}
    if sub == "seed_pair":
        s0 = ch.choice([0, 1, 12345, 2**31, 2**32 - 1])
        L.add(f"A = tx.render(scene, 16, 16, 1, seed={s0}, specialize=False)")
        L.add(f"B = tx.render(scene, 16, 16, 1, seed={s0} + 2**32, specialize=False)")
        L.add(f"C = tx.render(scene, 16, 16, 1, seed={s0} + 1, specialize=False)")
        L.add("RESULT = [A, B, C]")
        return Case("render_args", L.text(), differ=True)
    if sub == "env":
        env["PYOPENCL_CTX"] = ch.choice(_CTX_ENVS)
        L.add(f"RESULT = {call('tx.render', Code('scene'), w, h, spp, **kw)}")
        return Case("render_args", L.text(), env=env)
    args = [w, h, spp]
    for i, pool in enumerate((_SIZES, _SIZES, _SPPS)):
        if ch.boolean(0.25):
            args[i] = ch.choice(pool)
            if _is_num(args[i]) and not isinstance(args[i], bool) and args[i] <= 0:
                reject = reject or f"{['width', 'height', 'spp'][i]} = {args[i]!r}"
            if isinstance(args[i], bool) or isinstance(args[i], float):
                reject = reject or f"{['width', 'height', 'spp'][i]} = {args[i]!r} (not an int)"
    opts = {
        "seed": _SEEDS, "device": _DEVICES,
        "local_size": [None, 0, 1, 3, 7, 64, 1024, 4096, -1, 2**32, 1.5, "64", True],
        "tile_pixels": [1, 7, 2**20, 0, -1, 2**63, 1.5, 16],
        "memory_limit": [1, 1000, 2**20, 0, -1, 2**63, 1e9, 2**40],
        "aovs": [("uv",), "uv", ("depth", "object_id"), tuple(AOV_NAMES), ("bogus",), None, 5, ("uv", "uv"), (),
                 ["normal"], ("UV",)],
        "pipeline": ["fused", "stages", "x", None, ""],
        "progress": [Code("lambda f: None"), 1, "x", Code("print")],
        "sink": [Code("lambda y0, rgb, aov: None"), 1, "x"],
        "texture_filter": [None, "nearest", "trilinear", "anisotropic", "x", 1],
        "specialize": [True, False, 0, "no", None],
        "jitter": [False, 0, "x"], "shadows": [False, 1, None],
        "light_sampling": ["one", "all", "x", None, 1, "ONE"],
        "compiled": [Code("texray.compile.compile_scene(scene)"), "x", 1],
    }
    for name in ch.choice([1, 1, 2, 3]) * [None]:
        key = ch.choice(list(opts))
        kw[key] = ch.choice(opts[key])
    if kw.get("device") == "":                  # (after the loop: a later draw may replace it)
        reject = reject or "device = '' (no device is named '')"
    L.add(f"RESULT = {call('tx.render', Code('scene'), *args, **kw)}")
    if sub == "to_file":
        path = ch.choice(["tmp('out.png')", "tmp('out.exr')", "tmp('out.xyz')", "tmp()", "tmp('no/such/dir/out.png')",
                          f"tmp('{'a' * 300}.png')", "'/dev/null'", "tmp('out.hdr')", "tmp('out.jpg')", "None"])
        L.lines[-1] = (f"stats = {call('tx.render_to_file', Code('scene'), Code(path), *args, **{k: v for k, v in kw.items() if k not in ('sink',)})}")
        L.add("RESULT = tx.Image(np.zeros((1, 1, 3), np.float32))")
    return Case("render_args", L.text(), must_reject=reject, env=env)


# =============================================================================
# Family: mutated scene files (through Scene.load + render, and the CLI)
# =============================================================================

_SCENE_CACHE = {}


def shipped_scenes():
    return [p for p in sorted(SCENES.rglob("*.toml")) if not any(str(p).endswith(s) for s in SKIP_SCENES)]


def _parsed(path):
    if path not in _SCENE_CACHE:
        _SCENE_CACHE[path] = tomllib.loads(path.read_text(encoding="utf-8"))
    import copy
    return copy.deepcopy(_SCENE_CACHE[path])


def _locations(node, prefix=()):
    """Every (parent, key, path) below ``node``, depth first, in document order."""
    out = []
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        out.append((node, k, prefix + (k,)))
        out.extend(_locations(v, prefix + (k,)))
    return out


def _path_str(path):
    s = ""
    for k in path:
        s += f"[{k}]" if isinstance(k, int) else (f".{k}" if s else str(k))
    return s


_SPECIAL_PATHS = ["missing", "directory", "long_name", "deep_path", "dev_zero", "fifo", "random_bytes", "truncated",
                  "other_kind", "empty_string", "dot", "null_byte", "empty_file", "absolute_dir", "wrong_ext_copy"]


def _special_path(ch, L, original, i):
    """A replacement for a path string of a scene file; the files it needs are made by the case's code."""
    ext = os.path.splitext(original)[1] or ".png"
    src_rel = os.path.relpath(original, SCENES) if os.path.isabs(original) else None
    k = ch.choice(_SPECIAL_PATHS)
    name = f"p{i}{ext}"
    if k == "missing":
        return f"missing{i}{ext}", k
    if k == "directory":
        L.add(f"directory({name!r})")
        return name, k
    if k == "long_name":
        return "a" * ch.integer(250, 300) + ext, k
    if k == "deep_path":
        return ("d" * 200 + "/") * 21 + name, k
    if k == "dev_zero":
        return "/dev/zero", k
    if k == "fifo":
        L.add(f"fifo({name!r})")
        return name, k
    if k == "random_bytes":
        L.add(f"random_bytes({name!r}, {ch.integer(0, 3000)}, seed={ch.integer(0, 999)})")
        return name, k
    if k == "truncated" and src_rel and os.path.isfile(original):   # a real asset (not /dev/zero)
        L.add(f"truncated({name!r}, {src_rel!r}, {r3(ch.floats(0, 0.99))})")
        return name, k
    if k == "other_kind":
        return (asset("meshes/torus.obj") if ext != ".obj" else asset("textures/checker.png")), k
    if k == "wrong_ext_copy":
        other = "meshes/torus.obj" if ext != ".obj" else "textures/checker.png"
        L.add(f"copy_asset({name!r}, {other!r})")
        return name, k
    if k == "empty_string":
        return "", k
    if k == "dot":
        return ".", k
    if k == "null_byte":
        return f"a\x00b{ext}", k
    if k == "empty_file":
        L.add(f"random_bytes({name!r}, 0, seed=0)")
        return name, k
    if k == "absolute_dir":
        return str(SCENES), k
    return f"missing{i}{ext}", "missing"


def _mutate(ch, doc, L, i):
    """Apply one mutation to ``doc``; returns its description."""
    locs = _locations(doc)
    op = ch.choice(["number", "number", "wrong_type", "drop", "unknown_key", "array", "path", "string", "duplicate",
                    "vector"])
    if op == "number":
        cands = [l for l in locs if _is_num(l[0][l[1]])]
        if cands:
            parent, key, path = ch.choice(cands)
            pool = EXTREME_COUNTS if path[0] == "render" else EXTREME_NUMBERS
            parent[key] = ch.choice(pool)
            return f"{_path_str(path)} = {parent[key]!r}"
    if op == "vector":
        cands = [l for l in locs if isinstance(l[0][l[1]], list) and l[0][l[1]] and all(_is_num(x) for x in l[0][l[1]])]
        if cands:
            parent, key, path = ch.choice(cands)
            v = ch.choice(EXTREME_NUMBERS)
            parent[key] = [v] * len(parent[key])
            return f"{_path_str(path)} = all {v!r}"
    if op == "wrong_type" and locs:
        parent, key, path = ch.choice(locs)
        parent[key] = copy.deepcopy(ch.choice(WRONG_TYPES))   # a copy: the shared values stay as they are
        return f"{_path_str(path)} = {parent[key]!r} (wrong type)"
    if op == "drop":
        cands = [l for l in locs if isinstance(l[0], dict)] + [(doc, k, (k,)) for k in doc]
        if cands:
            parent, key, path = ch.choice(cands)
            if key in parent:
                del parent[key]
                return f"drop {_path_str(path)}"
    if op == "unknown_key":
        tables = [doc] + [l[0][l[1]] for l in locs if isinstance(l[0][l[1]], dict)]
        t = ch.choice(tables)
        key = ch.choice(["fuzz", "radius", "file", "procedural", "type", "texture", "width", "mesh", "p0", "uvs",
                         "params", "filter", "scale"])
        val = ch.choice([1, 0.5, "x", [1, 2, 3], {"a": 1}, True])
        t[key] = val
        return f"add key {key} = {val!r}"
    if op == "array":
        cands = [l for l in locs if isinstance(l[0][l[1]], list)]
        if cands:
            parent, key, path = ch.choice(cands)
            a = parent[key]
            how = ch.choice(["ragged", "shorter", "longer", "nested", "empty", "flatten"])
            if how == "ragged" and a:
                j = ch.integer(0, len(a) - 1)
                a[j] = [a[j], a[j]] if not isinstance(a[j], list) else a[j][:-1]
            elif how == "shorter" and a:
                a.pop()
            elif how == "longer":
                a.append(a[-1] if a else 1)
            elif how == "nested":
                parent[key] = [a]
            elif how == "flatten":
                parent[key] = [x for y in a for x in (y if isinstance(y, list) else [y])]
            else:
                parent[key] = []
            return f"{_path_str(path)}: array {how}"
    if op == "path":
        cands = [l for l in locs if l[1] in ("file", "mesh") and isinstance(l[0][l[1]], str)]
        if cands:
            parent, key, path = ch.choice(cands)
            parent[key], k = _special_path(ch, L, parent[key], i)
            return f"{_path_str(path)} = {k}"
    if op == "string":
        cands = [l for l in locs if isinstance(l[0][l[1]], str) and l[1] not in ("file", "mesh")]
        if cands:
            parent, key, path = ch.choice(cands)
            names = [n for t in ("textures", "materials") for n in doc.get(t, {})] if isinstance(doc.get("textures", {}), dict) and isinstance(doc.get("materials", {}), dict) else []
            parent[key] = ch.choice(STRINGS + names)
            return f"{_path_str(path)} = {parent[key]!r}"
    if op == "duplicate":
        cands = [l for l in locs if isinstance(l[0], list) and isinstance(l[0][l[1]], dict)]
        if cands:
            parent, key, path = ch.choice(cands)
            n = ch.integer(1, 8)
            for _ in range(n):
                parent.insert(key, copy.deepcopy(parent[key]))
            return f"{_path_str(path)} x{n + 1}"
    # fallback: an extreme number anywhere
    cands = [l for l in locs if _is_num(l[0][l[1]])]
    if cands:
        parent, key, path = ch.choice(cands)
        parent[key] = ch.choice(EXTREME_NUMBERS)
        return f"{_path_str(path)} = {parent[key]!r}"
    return "none"


def _absolute_paths(doc, base):
    for t in (doc.get("textures") or {}).values():
        if isinstance(t, dict) and isinstance(t.get("file"), str):
            t["file"] = str((base / t["file"]).resolve())
    for o in doc.get("objects") or []:
        if isinstance(o, dict) and isinstance(o.get("mesh"), str):
            o["mesh"] = str((base / o["mesh"]).resolve())


def gen_scene_file(ch) -> Case:
    L = _Lines()
    scenes = shipped_scenes()
    path = ch.choice(scenes)
    doc = _parsed(path)
    _absolute_paths(doc, path.parent)
    doc["render"] = {"width": ch.integer(4, 32), "height": ch.integer(4, 32), "spp": ch.integer(1, 2),
                     **({"seed": ch.integer(0, 99)} if ch.boolean(0.3) else {})}
    muts = [_mutate(ch, doc, L, i) for i in range(ch.integer(1, 4))]
    L.lines.insert(0, f"# {path.relative_to(ROOT)}; mutations: {'; '.join(muts)}")
    try:
        text = toml_dumps(doc)
    except TypeError as e:
        text = f"# cannot write: {e}\n"
    L.add(f"SCENE = write_text('scene.toml', {_text_literal(text)})")
    reject = None
    if ch.boolean(0.3):
        argv = ["render", Code("SCENE"), "-o", Code(f"tmp({ch.choice(['out.png'] * 6 + ['out.exr', 'out.jpg', 'out.tif', 'out.xyz', 'out.hdr'])!r})")]
        if ch.boolean(0.15):
            argv[3] = Code(ch.choice(["tmp()", "tmp('no/dir/out.png')", f"tmp('{'o' * 300}.png')", "'/dev/null'", "''"]))
        for opt, pool in (("--width", ["16", "0", "-1", "4294967296", "abc", "1.5", "", "9223372036854775808"]),
                          ("--height", ["12", "0", "-1", "4294967296", "abc"]),
                          ("--spp", ["1", "0", "-1", "4294967296", "x"]),
                          ("--seed", ["3", "-1", "18446744073709551616", "x"]),
                          ("--device", ["cpu", "0", "7", "abc", "", "gpu", "-1"])):
            if ch.boolean(0.25):
                v = ch.choice(pool)
                argv += [opt, v]
                if opt in ("--width", "--height", "--spp") and v in ("0", "-1"):
                    reject = reject or f"{opt} {v}"
                if opt == "--device" and v == "":
                    reject = reject or "--device ''"
        if ch.boolean(0.15):
            argv += ["--aov", ch.choice(AOV_NAMES + ["bogus"])]
        if ch.boolean(0.05):
            argv = ch.choice([[], ["render"], ["render", Code("SCENE")], ["devices"], ["bogus"], ["render", "--help"]])
            reject = None
        L.add(f"RESULT = cli({lit(argv)})")
    else:
        L.add("scene = load_scene(SCENE)")
        L.add(f"RESULT = render_settings(scene, specialize={weighted(ch, [(3, False), (1, True)])})")
    return Case("scene_file", L.text(), must_reject=reject)


_GLTF_BASE = {}


def _gltf_base(kind):
    """A small valid glTF document (dict) with everything the reader reads: a node
    hierarchy (TRS and matrix), two primitives with two materials (a base colour texture
    with a sampler and KHR_texture_transform, a metallic-roughness texture, a normal map),
    a camera, a point and a spot light; buffers and images as data: URIs."""
    if kind not in _GLTF_BASE:
        import importlib.util
        spec = importlib.util.spec_from_file_location("gltf_writer", ROOT / "tools" / "gltf_writer.py")
        gw = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(gw)
        import json
        import numpy as np
        w = gw.GltfWriter()
        w.use_extension("KHR_texture_transform")
        p = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float64)
        uv = gw.gltf_uvs([[0, 0], [1, 0], [1, 1], [0, 1]])
        n = np.tile([0.0, 0.0, 1.0], (4, 1))
        img = w.image(np.random.default_rng(1).random((4, 4, 3)), embed="data")
        tex = w.texture(img, w.sampler(wrapS=33071, wrapT=10497, magFilter=9728))
        m0 = w.material(pbrMetallicRoughness={"baseColorTexture": {"index": tex, "extensions": {
            "KHR_texture_transform": {"offset": [0.1, 0.2], "rotation": 0.3, "scale": [2, 1]}}},
            "baseColorFactor": [0.8, 0.7, 0.6, 1], "metallicFactor": 0.2, "roughnessFactor": 0.5})
        m1 = w.material(pbrMetallicRoughness={"metallicRoughnessTexture": {"index": w.texture(img)}},
                        normalTexture={"index": w.texture(img), "scale": 0.7})
        prims = [w.primitive(p, np.array([[0, 1, 2]]), uvs=uv, normals=n, material=m0),
                 w.primitive(p, np.array([[0, 2, 3]]), uvs=uv, normals=n, material=m1)]
        mesh = w.node(mesh=w.mesh(prims, name="quad"), translation=[0.0, 0.0, -1.0], rotation=[0, 0.1, 0, 0.995])
        group = w.node(children=[mesh], matrix=np.diag([1.5, 1.5, 1.5, 1.0]), name="group")
        cam = w.node(camera=w.camera(0.8, aspect_ratio=1.5), translation=[0.0, 0.0, 4.0], name="cam")
        lamp = w.node(translation=[1.0, 1.0, 3.0],
                      extensions={"KHR_lights_punctual": {"light": w.light("point", (1, 0.9, 0.8), 20.0)}})
        spot = w.node(translation=[-1.0, 1.0, 3.0], extensions={"KHR_lights_punctual": {"light": w.light(
            "spot", (1, 1, 1), 5.0, spot={"innerConeAngle": 0.2, "outerConeAngle": 0.5})}})
        w.scene([group, cam, lamp, spot])
        with tempfile.TemporaryDirectory() as d:
            path = w.write(Path(d) / "base.gltf", buffer="data")
            _GLTF_BASE[kind] = json.loads(Path(path).read_text())
    return copy.deepcopy(_GLTF_BASE[kind])


def gen_gltf_file(ch) -> Case:
    """A mutated small glTF file through tx.Scene.load + render, or tx.Mesh.load: every
    outcome is a render with finite pixels or a SceneError naming the file."""
    import json
    L = _Lines()
    doc = _gltf_base("quad")
    muts = [_mutate(ch, doc, L, i) for i in range(ch.integer(1, 4))]
    L.lines.insert(0, f"# mutations: {'; '.join(muts)}")
    L.add(f"PATH = write_text('scene.gltf', {_text_literal(json.dumps(doc))})")
    if ch.boolean(0.7):
        L.add("scene = load_scene(PATH)")
    else:
        L.add("scene = tx.Scene(lights=[tx.PointLight((1, 2, 5))])")
        L.add("scene.add(tx.Mesh.load(PATH))")
    L.add(f"RESULT = render_settings(scene, specialize={weighted(ch, [(3, False), (1, True)])})")
    return Case("gltf_file", L.text())


# =============================================================================
# Entry points
# =============================================================================

FAMILIES = {"scene_file": gen_scene_file, "geometry": gen_geometry, "texture": gen_texture,
            "render_args": gen_render_args, "random_scene": gen_random_scene, "extreme_scene": gen_extreme_scene,
            "post_edit": gen_post_edit, "gltf_file": gen_gltf_file}
# How often each family is drawn by generate() (campaigns).
FAMILY_WEIGHTS = [(3, "scene_file"), (2, "geometry"), (2, "texture"), (1, "render_args"), (2, "random_scene"),
                  (2, "extreme_scene"), (1, "post_edit"), (1, "gltf_file")]


def generate(ch, family=None) -> Case:
    """One case: of ``family``, or of a family drawn by FAMILY_WEIGHTS."""
    family = family or weighted(ch, FAMILY_WEIGHTS)
    return FAMILIES[family](ch)


def campaign_case(seed, k, family=None) -> Case:
    """Case k of campaign ``seed``: determined by (seed, k) (and the family filter) alone."""
    case = generate(RandomChooser(f"texray-fuzz:{seed}:{k}:{family or ''}"), family)
    case.label = f"seed {seed} case {k}" + (f" family {family}" if family else "")
    return case


if __name__ == "__main__":
    if len(sys.argv) >= 2 and sys.argv[1] == "--serve":
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        import fuzz_cases
        fuzz_cases._serve(int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]))
    else:
        print(__doc__)
