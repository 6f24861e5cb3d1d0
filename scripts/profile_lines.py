"""Where inside the Warp kernels a frame's CPU time goes: a sampled profile by function and by statement.

    .venv/bin/python scripts/profile_lines.py SCENE [--mode raster|hybrid|full] [--size 640x480] [--frames 30]
        [--threads N] [--kernel REGEX] [--top 30]

``profile_frame.py`` times whole kernels; this goes inside them.  The kernels are compiled
with line tables (clang's ``-debug-info-kind=line-tables-only``: the same optimised code,
plus the map from instructions to source lines) into a kernel cache of their own
(``build/warp-cache-lines``, so the renderer's own cache is untouched).  After a warm-up
frame it writes ``/tmp/perf-PID.map`` for the code Warp's JIT loaded (every loaded
module's object file from the cache, placed where its kernels' entry points are), records
``--frames`` frames with ``perf record``, then prints each function's share of the samples
and, for the functions whose name matches ``--kernel``, the share of each statement: the
innermost line of the generated C++ a sample falls in, named by the Python line Warp's
code generator wrote above it.

Reading it: a sample lands on the instruction that waits, often the one after a slow load
or a call, so a call site's share is usually its callee's stall, not the call (forcing
such calls inline changed nothing, docs/speed_journal.md, "Grouped launches").  Confirm a reading with
a paired timing before changing code.  Linux only: needs ``perf`` and binutils
(``readelf``, ``addr2line``, ``c++filt``).
"""

from __future__ import annotations

import argparse
import bisect
import collections
import ctypes
import os
import re
import shutil
import signal
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

import warp as wp
from bench_common import ROOT

#: Line tables only: the generated code is what the renderer runs.
LINE_TABLE_FLAGS = "-debug-info-kind=line-tables-only -dwarf-version=4"
TOOLS = ("perf", "readelf", "addr2line", "c++filt")


@dataclass(frozen=True)
class JitSymbol:
    """A function of a loaded module: where it runs, its size, and where it lies in the object file."""

    address: int
    size: int
    name: str
    obj: Path
    section: str
    offset: int


def _run(cmd: list[str]) -> str:
    """A tool's standard output (it must succeed)."""
    return subprocess.run(cmd, capture_output=True, text=True, check=True).stdout


def _code_section(obj: Path) -> str:
    """The name of the object file's largest executable section (``.ltext`` for Warp's CPU code)."""
    best = ("", -1)
    for line in _run(["readelf", "-SW", str(obj)]).splitlines():
        m = re.match(r"\s*\[\s*\d+\]\s+(\S+)\s+\S+\s+[0-9a-f]+\s+[0-9a-f]+\s+([0-9a-f]+)\s+\S+\s+(\S+)", line)
        if m and "X" in m.group(3) and int(m.group(2), 16) > best[1]:
            best = (m.group(1), int(m.group(2), 16))
    return best[0]


def _object_symbols(obj: Path, section: str) -> dict[str, tuple[int, int, str]]:
    """Mangled name -> (offset, size, readable name without its arguments) of the
    functions in ``section`` of ``obj``."""
    sections = re.findall(r"^\s*\[\s*(\d+)\]\s+(\S+)", _run(["readelf", "-SW", str(obj)]), re.M)
    index = next(i for i, name in sections if name == section)
    rows = [line.split() for line in _run(["readelf", "-sW", str(obj)]).splitlines()]
    # readelf prints a size of 100000 bytes or more in hex ("0x186a0")
    funcs = [(r[7], int(r[1], 16), int(r[2], 0)) for r in rows if len(r) == 8 and r[3] == "FUNC" and r[6] == index]
    names = subprocess.run(
        ["c++filt"], input="\n".join(f[0] for f in funcs), capture_output=True, text=True, check=True
    ).stdout.splitlines()
    return {m: (off, size, name.split("(")[0]) for (m, off, size), name in zip(funcs, names)}


def jit_symbols(cache_dir: Path) -> list[JitSymbol]:
    """Every function of every Warp module loaded on the CPU, at its address in this process
    (each module's object file is placed by one of its kernels' entry points)."""
    from warp._src import context

    symbols: list[JitSymbol] = []
    for module in list(context.user_modules.values()):
        cpu = [(key, ex) for key, ex in getattr(module, "execs", {}).items() if key[0] is None]
        if not cpu:
            continue
        (key, ex), *_ = cpu
        objs = sorted(cache_dir.rglob(f"{module.get_module_identifier(key[1])}/*.o"))
        if not objs:
            continue
        obj = objs[0]
        section = _code_section(obj)
        table = _object_symbols(obj, section)
        entries = [(k, ex.get_kernel_mangled_name(k) + "_cpu_forward") for k in module.kernels.values()]
        placed = [(k, e) for k, e in entries if e in table]
        if not placed:
            continue
        kernel, entry = placed[0]
        base = ctypes.cast(ex.get_kernel_hooks(kernel).forward, ctypes.c_void_p).value - table[entry][0]
        symbols += [JitSymbol(base + off, size, short, obj, section, off) for off, size, short in table.values()]
    return sorted(symbols, key=lambda s: s.address)


def write_perf_map(symbols: list[JitSymbol]) -> Path:
    """``/tmp/perf-PID.map`` for ``perf`` to name the JIT code (start size name per line)."""
    path = Path(f"/tmp/perf-{os.getpid()}.map")
    path.write_text("".join(f"{s.address:x} {s.size:x} {s.name}\n" for s in symbols))
    return path


def sample_addresses(perf_data: Path) -> list[int]:
    """The instruction address of every sample ``perf record`` took."""
    return [int(ip, 16) for ip in _run(["perf", "script", "-i", str(perf_data), "-F", "ip"]).split()]


def by_symbol(symbols: list[JitSymbol], addresses: list[int]) -> tuple[collections.Counter, dict]:
    """Samples per function name (``<other>``: Python, Warp's runtime, the kernel), and
    per (symbol, offset in its object file) for the statement table."""
    starts = [s.address for s in symbols]
    per_name: collections.Counter = collections.Counter()
    per_offset: dict[JitSymbol, collections.Counter] = collections.defaultdict(collections.Counter)
    for ip in addresses:
        i = bisect.bisect_right(starts, ip) - 1
        if i >= 0 and ip < symbols[i].address + max(symbols[i].size, 1):
            s = symbols[i]
            per_name[s.name] += 1
            per_offset[s][ip - s.address + s.offset] += 1
        else:
            per_name["<other>"] += 1
    return per_name, per_offset


def _python_line(cpp: list[str], line: int) -> str:
    """The Python source of generated line ``line`` (1-based): ``file.py:N  text`` from the
    comment Warp's code generator wrote above it, or, inside a ``wp.func_native`` body
    (no such comments), ``file.py:N  native NAME: C++ text`` (N the function's own line,
    the text that of the generated line itself, so a native loop's lines stay apart)."""
    text, number = "?", None
    for k in range(line - 1, -1, -1):
        m = re.search(r"//(.*)<L (\d+)>\s*$", cpp[k])
        if m and number is None:
            text, number = m.group(1).strip(), m.group(2)
        header = re.match(r"^// (\S+\.py):(\d+)\s*$", cpp[k])
        if header:
            source = Path(header.group(1)).name
            if number is not None:
                return f"{source}:{number}  {text}"
            name = re.search(r"(\w+)\(", " ".join(cpp[k + 1 : k + 3]))
            native = name.group(1) if name else "?"
            return f"{source}:{header.group(2)}  native {native}: {cpp[line - 1].strip()[:90]}"
    return text


def by_statement(symbol: JitSymbol, offsets: collections.Counter) -> collections.Counter:
    """Samples per Python statement of one function: each address's innermost line in
    the module's generated C++ (inlined callees included)."""
    addresses = sorted(offsets)
    chains: dict[int, list[str]] = {}
    current = -1
    lines = _run(["addr2line", "-i", "-a", "-e", str(symbol.obj), "-j", symbol.section, *map(hex, addresses)])
    for line in lines.splitlines():
        if line.startswith("0x"):
            current = int(line, 16)
            chains[current] = []
        else:
            chains[current].append(line.split(" ")[0])
    cpp_files = list(symbol.obj.parent.glob("*.cpp"))
    cpp = cpp_files[0].read_text().splitlines() if cpp_files else []
    out: collections.Counter = collections.Counter()
    for address, count in offsets.items():
        frames = [f for f in chains.get(address, []) if ".cpp:" in f and not f.endswith("?")]
        out[_python_line(cpp, int(frames[0].rsplit(":", 1)[1])) if frames and cpp else "?"] += count
    return out


def main() -> None:
    """Compile with line tables, record, and print the two tables."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--mode", default="raster", choices=("raster", "hybrid", "full"))
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--kernel", default=None, help="regex: per-statement table for the functions it matches")
    ap.add_argument("--top", type=int, default=30)
    args = ap.parse_args()
    missing = [t for t in TOOLS if shutil.which(t) is None]
    if missing:
        raise SystemExit(f"profile_lines.py needs {', '.join(missing)} (Linux perf and binutils)")
    # before the renderer's modules are imported: the lighting module adds its flags to these
    wp.config.cpu_compiler_flags = f"{wp.config.cpu_compiler_flags or '-march=native'} {LINE_TABLE_FLAGS}"
    from warp_hybrid.renderer import Renderer, RenderSettings
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.open import open_scene_source

    cache_dir = ROOT / "build" / "warp-cache-lines"
    init_warp(str(cache_dir))
    width, height = (int(v) for v in args.size.split("x"))
    scene = open_scene_source(args.scene).scene_at(None)
    camera = scene.cameras[0]
    settings = RenderSettings(width=width, height=height, mode=args.mode, threads=args.threads)
    perf_data = ROOT / "build" / "profile_lines.perf.data"
    with Renderer(scene, settings) as r:
        r.warm_up(camera)
        r.render(camera)
        symbols = jit_symbols(cache_dir)
        perf_map = write_perf_map(symbols)
        cmd = ["perf", "record", "-F", "4000", "-p", str(os.getpid()), "-o", str(perf_data)]
        recorder = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(1.0)  # perf attaches
        frames = [r.render(camera).stats["frame_ms"] for _ in range(args.frames)]
        recorder.send_signal(signal.SIGINT)
        recorder.wait()
    per_name, per_offset = by_symbol(symbols, sample_addresses(perf_data))
    perf_map.unlink()
    total = sum(per_name.values())
    print(f"{args.scene}: --mode {args.mode}, {width}x{height}, {args.frames} frames ({min(frames):.1f} ms fastest)")
    print(f"{total} samples; by function:")
    for name, n in per_name.most_common(args.top):
        print(f"{100.0 * n / total:5.1f}%  {name[:120]}")
    if args.kernel:
        for symbol, offsets in sorted(per_offset.items(), key=lambda kv: -sum(kv[1].values())):
            if re.search(args.kernel, symbol.name):
                n = sum(offsets.values())
                print(f"\n{symbol.name[:120]}: {n} samples ({100.0 * n / total:.1f}%), by statement:")
                for statement, count in by_statement(symbol, offsets).most_common(args.top):
                    print(f"{100.0 * count / n:5.1f}%  {statement[:140]}")


if __name__ == "__main__":
    main()
