"""Native band threads: the bands of a CPU pass run by threads that stay in native code.

A CPU pass is cut into bands (``parallel``), each band one call of a kernel's compiled
entry point ``forward(&bounds, &args)`` with its own dimension and trailing integers (or,
in a pass of two *stages*, the tracer's shadows then paths, one call of each in order).
Handing bands to Python threads costs, per pass, a thread's wake-up (40-160 us, more on
a virtual machine) and, per band, ~15 us of Python taken in turns under the GIL.  Here
the helper threads never come back to Python while they have work: each sits in a
native loop (a one-item Warp kernel, ``_worker_kernel``) that watches a shared *board*
and takes bands as they are posted, spinning for a short while after the last one
(``SPIN_NS_DEFAULT``), then sleeping on a pthread condition variable (at once after
``BandPool.nap``) until a pass is posted or ``BandPool.wake`` calls them to spin
again.  The caller posts a pass (``BandPool.run``: one more native call with the GIL
released), takes bands itself and returns once every band taken is done; or, posting
without waiting, returns at once and takes part later (``BandPool.join``, or its next
pass, whose native post first finishes it: no Python between the two), the helpers
working on the pass meanwhile.  A pass's fields are written beside the board first
(``_staged``, while the pass before runs) and copied onto it by the native post.

The board (an int64 Warp array) holds one pass at a time:

- ``TICKET``: the pass number (24 bits), its band count (20 bits) and the next band
  not yet taken (20 bits) in one word, so a thread takes band k by one compare-and-swap
  and a thread that read an older pass's fields fails its swap (the caller rewrites the
  fields only when every band of the last pass is done, and bumps the pass number when
  it posts).  A band refused by the pass's deadline closes the pass by setting the
  count to its index, so the bands that run are always a prefix;
- ``DONE``: bands finished; the caller waits until it equals the count;
- the pass's fields: per stage the kernel's entry point, each thread's argument block
  (a packed ``ctypes`` structure the thread alone writes its band's trailing integers
  into) and the trailing integers' byte offsets; the deadline (``CLOCK_MONOTONIC`` ns)
  and what the bands done so far took; and the band table (``BAND_COLUMNS`` int64 per
  band: per stage its launch dimension and trailing integers, its items and whether it
  must run, and, written back, the thread that ran it and each stage's wall and thread
  CPU nanoseconds).

The layouts this relies on are Warp's: a CPU kernel's ``forward(launch_bounds_t*,
wp_args*)`` (its arguments packed in order, as ``warp.context.invoke`` packs them) and a
one- or two-dimensional ``launch_bounds_t`` (two uint32 extents, then size and
coord_mult as size_t); ``layout_matches`` checks the latter against Warp's own
``ctypes`` definition, and ``parallel.Launcher`` falls back to Python threads where it
does not hold (or off POSIX: the sleep uses pthreads).
"""

from __future__ import annotations

import ctypes
import os
import threading
import time
import warnings
import weakref
from collections.abc import Sequence
from typing import Any

import numpy as np
import warp as wp

# the board's slots (int64 each): the pass, then per stage its kernel, trailing integers
# and each thread's argument block, then the pthread objects and functions
(
    TICKET,
    DONE,
    SLEEPERS,
    QUIT,
    NAP,
    BANDS,
    STAGES,
    TIMED,
    SPIN_NS,
    DEADLINE_NS,
    BUSY_NS,
    ITEMS_DONE,
    RAN,
    WAKE,
) = range(14)
MAX_STAGES = 2
MAX_TAIL = 4
MAX_THREADS = 16
FN = WAKE + 1  # .. + MAX_STAGES: each stage's kernel entry point
TAILS = FN + MAX_STAGES  # .. + MAX_STAGES: each stage's count of trailing integers
TAIL_OFFSETS = TAILS + MAX_STAGES  # + stage * MAX_TAIL + i: their byte offsets
ARGS = TAIL_OFFSETS + MAX_STAGES * MAX_TAIL  # + stage * MAX_THREADS + slot: argument blocks
MUTEX, COND, LOCK_FN, UNLOCK_FN, WAIT_FN, BROADCAST_FN, CLOCK_FN, CLOCK_WALL, CLOCK_CPU = range(
    ARGS + MAX_STAGES * MAX_THREADS, ARGS + MAX_STAGES * MAX_THREADS + 9
)
BOARD_SIZE = CLOCK_CPU + 1
#: ``DEADLINE_NS`` of a pass with no deadline
NO_DEADLINE = (1 << 63) - 1

# A band's row in the band table: per stage its launch dimension (two extents; a stage of
# size 0 is skipped) and trailing integers (``STAGE_COLUMNS`` each); its items (what the
# deadline's estimate counts) and whether it runs whatever the deadline; then, written
# back, the thread that ran it and each stage's wall and thread CPU ns.
STAGE_COLUMNS = 2 + MAX_TAIL
COL_ITEMS = MAX_STAGES * STAGE_COLUMNS
COL_MUST = COL_ITEMS + 1
COL_SLOT = COL_MUST + 1
COL_WALL_NS = COL_SLOT + 1  # + stage
COL_CPU_NS = COL_WALL_NS + MAX_STAGES  # + stage
BAND_COLUMNS = COL_CPU_NS + MAX_STAGES

# bits of TICKET: pass number | band count | next band
BAND_BITS = 20
MAX_BANDS = (1 << BAND_BITS) - 1

# how long a helper thread spins after its last band before it sleeps (the gaps between
# a frame's passes are the caller's Python, tens to hundreds of microseconds)
SPIN_NS_DEFAULT = 2_000_000

_BOARD_CPP = f"""
#if defined(__CUDA_ARCH__)
return 0;
#else
#if defined(__x86_64__) || defined(__i386__)
#define WH_PAUSE() __builtin_ia32_pause()
#elif defined(__aarch64__)
#define WH_PAUSE() __asm__ __volatile__("yield")
#else
#define WH_PAUSE()
#endif
long long* b = (long long*)board.data;
struct Bounds {{ unsigned int shape[2]; unsigned long long size; unsigned long long coord_mult; }};
struct TimeSpec {{ long long sec; long long nsec; }};
typedef void (*Forward)(void*, void*);
typedef wp::int32 (*PthreadFn)(void*);
typedef wp::int32 (*WaitFn)(void*, void*);
typedef wp::int32 (*ClockFn)(long long, TimeSpec*);
const ClockFn clock_fn = (ClockFn)b[{CLOCK_FN}];
auto now_ns = [&](long long clock) -> long long {{
    TimeSpec ts;
    clock_fn(clock, &ts);
    return ts.sec * 1000000000LL + ts.nsec;
}};
auto load = [&](int i) -> long long {{ return __atomic_load_n(&b[i], __ATOMIC_SEQ_CST); }};
auto field = [&](int i) -> long long {{ return __atomic_load_n(&b[i], __ATOMIC_RELAXED); }};
const unsigned long long mask = {MAX_BANDS}ULL;
// Take the next band of the posted pass and run its stages: false when none is left (true
// after a lost race too: try again).  Before a band that need not run, the deadline is
// asked (now plus its items at the mean time an item of the bands done so far); a band
// that would end after it closes the pass there (its band count becomes that band's index).
auto take = [&](int slot) -> bool {{
    unsigned long long t = (unsigned long long)load({TICKET});
    const long long n = (long long)((t >> {BAND_BITS}) & mask);
    const long long k = (long long)(t & mask);
    if (k >= n) return false;
    const long long stages = field({STAGES});
    Forward fn[{MAX_STAGES}];
    char* args[{MAX_STAGES}];
    long long tails[{MAX_STAGES}];
    long long offsets[{MAX_STAGES}][{MAX_TAIL}];
    for (int s = 0; s < stages; ++s) {{
        fn[s] = (Forward)field({FN} + s);
        args[s] = (char*)field({ARGS} + s * {MAX_THREADS} + slot);
        tails[s] = field({TAILS} + s);
        for (int i = 0; i < {MAX_TAIL}; ++i) offsets[s][i] = field({TAIL_OFFSETS} + s * {MAX_TAIL} + i);
    }}
    long long* const row = (long long*)field({BANDS}) + k * {BAND_COLUMNS};
    const long long deadline = field({DEADLINE_NS});
    const bool clocked = field({TIMED}) != 0 || deadline != {NO_DEADLINE}LL;
    bool go = true;
    if (deadline != {NO_DEADLINE}LL && row[{COL_MUST}] == 0) {{
        const long long items_done = load({ITEMS_DONE});
        const double per_item = items_done > 0 ? (double)load({BUSY_NS}) / (double)items_done : 0.0;
        go = (double)now_ns(b[{CLOCK_WALL}]) + (double)row[{COL_ITEMS}] * per_item <= (double)deadline;
    }}
    __atomic_thread_fence(__ATOMIC_SEQ_CST);
    if (!go) {{
        const unsigned long long closed = (t & ~((mask << {BAND_BITS}) | mask)) |
                                          ((unsigned long long)k << {BAND_BITS}) | (unsigned long long)k;
        __atomic_compare_exchange_n((unsigned long long*)&b[{TICKET}], &t, closed, false, __ATOMIC_SEQ_CST,
                                    __ATOMIC_SEQ_CST);
        return true;
    }}
    if (!__atomic_compare_exchange_n((unsigned long long*)&b[{TICKET}], &t, t + 1, false, __ATOMIC_SEQ_CST,
                                     __ATOMIC_SEQ_CST))
        return true;
    // band k of this pass is ours: its fields stay put until every band taken is done
    long long band_ns = 0;
    for (int s = 0; s < stages; ++s) {{
        const long long* const stage = row + s * {STAGE_COLUMNS};
        for (int i = 0; i < tails[s]; ++i) *(int*)(args[s] + offsets[s][i]) = (int)stage[2 + i];
        Bounds bounds;
        bounds.shape[0] = (unsigned int)stage[0];
        bounds.shape[1] = (unsigned int)stage[1];
        bounds.size = (unsigned long long)stage[0] * (unsigned long long)stage[1];
        bounds.coord_mult = 1;
        long long wall = 0, cpu = 0;
        if (clocked) {{ wall = now_ns(b[{CLOCK_WALL}]); cpu = now_ns(b[{CLOCK_CPU}]); }}
        if (bounds.size > 0) fn[s](&bounds, args[s]);
        if (clocked) {{
            row[{COL_WALL_NS} + s] = now_ns(b[{CLOCK_WALL}]) - wall;
            row[{COL_CPU_NS} + s] = now_ns(b[{CLOCK_CPU}]) - cpu;
            band_ns += row[{COL_WALL_NS} + s];
        }}
    }}
    row[{COL_SLOT}] = slot;
    if (deadline != {NO_DEADLINE}LL) {{
        __atomic_fetch_add(&b[{BUSY_NS}], band_ns, __ATOMIC_SEQ_CST);
        __atomic_fetch_add(&b[{ITEMS_DONE}], row[{COL_ITEMS}], __ATOMIC_SEQ_CST);
    }}
    __atomic_fetch_add(&b[{DONE}], 1, __ATOMIC_SEQ_CST);
    return true;
}};
auto has_work = [&]() -> bool {{
    const unsigned long long t = (unsigned long long)load({TICKET});
    return (t & mask) < ((t >> {BAND_BITS}) & mask);
}};
"""

_WORKER_CPP = (
    _BOARD_CPP
    + f"""
void* const mutex = (void*)b[{MUTEX}];
void* const cond = (void*)b[{COND}];
const PthreadFn lock = (PthreadFn)b[{LOCK_FN}];
const PthreadFn unlock = (PthreadFn)b[{UNLOCK_FN}];
const WaitFn wait = (WaitFn)b[{WAIT_FN}];
long long idle_since = now_ns(b[{CLOCK_WALL}]);
long long woken = load({WAKE});  // the wake-up calls seen (``BandPool.wake``)
for (int spins = 0;; ++spins) {{
    if (load({QUIT})) return 0;
    if (take(slot)) {{
        spins = 0;
        idle_since = now_ns(b[{CLOCK_WALL}]);
        continue;
    }}
    WH_PAUSE();
    if ((spins & 255) != 255) continue;
    if (load({WAKE}) != woken) {{  // told a pass is coming: spin afresh
        woken = load({WAKE});
        idle_since = now_ns(b[{CLOCK_WALL}]);
        continue;
    }}
    if (!load({NAP}) && now_ns(b[{CLOCK_WALL}]) - idle_since < b[{SPIN_NS}]) continue;
    // long idle, or told to nap: sleep until a pass is posted (the caller wakes the
    // sleepers after it posts) or a wake-up call comes
    lock(mutex);
    __atomic_fetch_add(&b[{SLEEPERS}], 1, __ATOMIC_SEQ_CST);
    while (!has_work() && !load({QUIT}) && load({WAKE}) == woken) wait(cond, mutex);
    __atomic_fetch_sub(&b[{SLEEPERS}], 1, __ATOMIC_SEQ_CST);
    unlock(mutex);
    woken = load({WAKE});
    idle_since = now_ns(b[{CLOCK_WALL}]);
}}
#endif
"""
)

# The caller's end of a pass: take bands until none is left, wait for the helpers' and
# write ``RAN`` (``finish``: for the pass in flight before the next is posted, and for
# the caller's own pass where it waits for it).
_FINISH_CPP = f"""
auto finish = [&]() {{
    while (take(0)) {{}}
    // no band is left to take or to refuse: the ticket's count is the bands taken
    const long long taken = (long long)(((unsigned long long)load({TICKET}) >> {BAND_BITS}) & mask);
    while (load({DONE}) < taken) WH_PAUSE();
    b[{RAN}] = taken;
}};
"""

# The caller's part of a pass whose fields ``BandPool._stage`` wrote into ``staged`` (the board's
# layout): with ``finish_first``, finish the pass in flight (those fields were written
# while it ran, so no Python lies between its end and the next pass's post); then copy
# the fields onto the board and post the pass (a new pass number, the bands, the sleepers
# woken); with ``join``, finish it too.  Without ``join`` the caller returns at once and
# the helpers run the pass while the caller does other work (``BandPool.run`` with
# ``wait=False``) until it joins (``_JOIN_CPP``, or the next pass's ``finish_first``).
_RUN_CPP = (
    _BOARD_CPP
    + _FINISH_CPP
    + f"""
if (finish_first != 0) finish();
const long long* st = (const long long*)staged.data;
auto copy = [&](int i) {{ __atomic_store_n(&b[i], st[i], __ATOMIC_RELAXED); }};
copy({STAGES}); copy({BANDS}); copy({TIMED}); copy({DEADLINE_NS});
for (int i = {FN}; i < {ARGS + MAX_STAGES * MAX_THREADS}; ++i) copy(i);
__atomic_store_n(&b[{DONE}], 0, __ATOMIC_SEQ_CST);
__atomic_store_n(&b[{NAP}], 0, __ATOMIC_SEQ_CST);
__atomic_store_n(&b[{BUSY_NS}], 0, __ATOMIC_SEQ_CST);
__atomic_store_n(&b[{ITEMS_DONE}], 0, __ATOMIC_SEQ_CST);
const unsigned long long last = (unsigned long long)load({TICKET});
const unsigned long long pass = ((last >> {2 * BAND_BITS}) + 1) & 0xFFFFFFULL;
__atomic_store_n((unsigned long long*)&b[{TICKET}], (pass << {2 * BAND_BITS}) | ((unsigned long long)bands << {BAND_BITS}),
                 __ATOMIC_SEQ_CST);
if (load({SLEEPERS}) > 0) {{
    ((PthreadFn)b[{LOCK_FN}])((void*)b[{MUTEX}]);
    ((PthreadFn)b[{BROADCAST_FN}])((void*)b[{COND}]);
    ((PthreadFn)b[{UNLOCK_FN}])((void*)b[{MUTEX}]);
}}
if (join != 0) finish();
return 0;
#endif
"""
)

# The caller joins the pass it posted without waiting: takes the bands left, waits for
# the helpers' and writes ``RAN``.
_JOIN_CPP = _BOARD_CPP + _FINISH_CPP + "finish();\nreturn 0;\n#endif\n"


def _wake_cpp(slot: int) -> str:
    """C++: add one to board slot ``slot`` (``QUIT``: the helpers return; ``WAKE``: the
    sleeping ones spin again), then wake every sleeper."""
    return f"""
#if defined(__CUDA_ARCH__)
return 0;
#else
long long* b = (long long*)board.data;
typedef wp::int32 (*PthreadFn)(void*);
__atomic_fetch_add(&b[{slot}], 1, __ATOMIC_SEQ_CST);
((PthreadFn)b[{LOCK_FN}])((void*)b[{MUTEX}]);
((PthreadFn)b[{BROADCAST_FN}])((void*)b[{COND}]);
((PthreadFn)b[{UNLOCK_FN}])((void*)b[{MUTEX}]);
return 0;
#endif
"""


@wp.func_native(_WORKER_CPP)
def _worker_loop(board: wp.array(dtype=wp.int64), slot: int) -> int: ...


@wp.func_native(_RUN_CPP)
def _run_pass(
    board: wp.array(dtype=wp.int64), staged: wp.array(dtype=wp.int64), bands: int, finish_first: int, join: int
) -> int: ...


@wp.func_native(_JOIN_CPP)
def _join_pass(board: wp.array(dtype=wp.int64)) -> int: ...


@wp.func_native(_wake_cpp(QUIT))
def _quit_workers(board: wp.array(dtype=wp.int64)) -> int: ...


@wp.func_native(_wake_cpp(WAKE))
def _wake_workers(board: wp.array(dtype=wp.int64)) -> int: ...


@wp.kernel
def _worker_kernel(board: wp.array(dtype=wp.int64), slot: int):
    _worker_loop(board, slot)


@wp.kernel
def _run_kernel(
    board: wp.array(dtype=wp.int64), staged: wp.array(dtype=wp.int64), bands: int, finish_first: int, join: int
):
    _run_pass(board, staged, bands, finish_first, join)


@wp.kernel
def _join_kernel(board: wp.array(dtype=wp.int64)):
    _join_pass(board)


@wp.kernel
def _quit_kernel(board: wp.array(dtype=wp.int64)):
    _quit_workers(board)


@wp.kernel
def _wake_kernel(board: wp.array(dtype=wp.int64)):
    _wake_workers(board)


@wp.kernel
def _probe_kernel(out: wp.array2d(dtype=wp.int32), first: int, value: int):
    """``probe_pool``'s pass: row ``first + r``, column c gets ``value + 10 r + c``."""
    r, c = wp.tid()
    out[first + r, c] = value + 10 * r + c


def layout_matches() -> bool:
    """Whether this platform can run native band threads: POSIX threads and clocks, and
    Warp's one- and two-dimensional launch bounds laid out as the native loop writes them
    (two uint32 extents, then size and coord_mult as size_t)."""
    if os.name != "posix" or ctypes.sizeof(ctypes.c_void_p) != 8:
        return False
    from warp._src.types import launch_bounds_t

    for dim in ((1,), (1, 1)):
        cls = type(launch_bounds_t(dim))
        fields = {name: getattr(cls, name).offset for name, _ in cls._fields_}
        if fields != {"shape": 0, "size": 8, "coord_mult": 16} or ctypes.sizeof(cls) != 24:
            return False
    return True


class _Pthreads:
    """A pthread mutex and condition variable in ``ctypes`` memory, and the addresses of
    the functions the native loop calls on them."""

    def __init__(self) -> None:
        libc = ctypes.CDLL(None)
        self.mutex = ctypes.create_string_buffer(256)
        self.cond = ctypes.create_string_buffer(256)
        if libc.pthread_mutex_init(self.mutex, None) or libc.pthread_cond_init(self.cond, None):
            raise OSError("pthread_mutex_init / pthread_cond_init failed")
        self.functions = {
            LOCK_FN: libc.pthread_mutex_lock,
            UNLOCK_FN: libc.pthread_mutex_unlock,
            WAIT_FN: libc.pthread_cond_wait,
            BROADCAST_FN: libc.pthread_cond_broadcast,
            CLOCK_FN: libc.clock_gettime,
        }

    def write(self, board: np.ndarray) -> None:
        """Put the mutex, condition variable and functions' addresses on the board."""
        board[MUTEX] = ctypes.addressof(self.mutex)
        board[COND] = ctypes.addressof(self.cond)
        for slot, fn in self.functions.items():
            board[slot] = ctypes.cast(fn, ctypes.c_void_p).value


def _stop(run_quit: Any, threads: Sequence[threading.Thread], keep: tuple[Any, ...]) -> None:
    """Tell the helper threads to quit, wake them and wait for them (``keep``: the board
    and the pthread objects, alive until then)."""
    run_quit.launch()
    for thread in threads:
        thread.join()


# a kernel's argument block layout by (kernel, trailing integers, packed types): the ctypes
# structure and the trailing integers' byte offsets (making the structure type costs more
# than packing the arguments)
_LAYOUTS: dict[tuple[Any, ...], tuple[type[ctypes.Structure], list[int]]] = {}


class PackedKernel:
    """One thread's argument block for a kernel: its inputs packed as Warp packs a CPU
    launch's arguments, the last ``len(offsets)`` of them int32 slots that each band
    overwrites (their byte offsets in ``offsets``), and the kernel's entry point."""

    def __init__(self, args: ctypes.Structure, offsets: list[int], forward: int, owner: Any) -> None:
        """A block from its parts (``pack`` makes one; ``owner`` keeps what the packed
        arrays point to alive)."""
        self.args = args
        self.offsets = offsets
        self.forward = forward
        self._owner = owner

    @classmethod
    def pack(cls, kernel: wp.Kernel, device: wp.context.Device, inputs: Sequence[Any], tail: int) -> PackedKernel:
        """Pack ``inputs`` and ``tail`` zero integers for ``kernel`` on CPU ``device`` (the
        kernel's module loaded); the trailing inputs (at most ``MAX_TAIL``) must be int32."""
        if tail > MAX_TAIL:
            raise ValueError(f"kernel {kernel.key}: {tail} trailing integers, at most {MAX_TAIL}")
        cmd = wp.launch(kernel, dim=1, inputs=[*inputs, *([0] * tail)], device=device, record_cmd=True)
        if cmd.block_dim != 1:
            raise TypeError(f"kernel {kernel.key}: a CPU launch in blocks of {cmd.block_dim}")
        params = cmd.params[1:]
        key = (kernel, tail, tuple(type(value) for value in params))
        layout = _LAYOUTS.get(key)
        if layout is None:
            fields = [(arg.label, type(value)) for arg, value in zip(kernel.adj.args, params, strict=True)]
            for name, ctype in fields[len(fields) - tail :]:
                if ctype is not ctypes.c_int32:
                    raise TypeError(f"kernel {kernel.key}: trailing input {name} is {ctype.__name__}, not int32")
            struct = type("PackedArgs", (ctypes.Structure,), {"_fields_": fields})
            layout = _LAYOUTS[key] = (
                struct,
                [getattr(struct, name).offset for name, _ in fields[len(fields) - tail :]],
            )
        struct, offsets = layout
        return cls(struct(*params), offsets, ctypes.cast(cmd.hooks.forward, ctypes.c_void_p).value, cmd)

    def copy(self) -> PackedKernel:
        """Another block with the same contents (for another thread)."""
        return PackedKernel(type(self.args).from_buffer_copy(self.args), self.offsets, self.forward, self._owner)

    @property
    def address(self) -> int:
        """Where the argument block lies."""
        return ctypes.addressof(self.args)


class DirectLaunch:
    """A one-item CPU launch of a kernel, called straight through its compiled entry point
    with its arguments packed once (``PackedKernel``), its trailing integers set per call:
    a recorded ``wp.Launch`` packs a new argument structure on every ``launch`` (about
    10 us, paid by every pass the band threads run).  The call releases the GIL, as
    Warp's own does."""

    _FORWARD = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)

    def __init__(self, kernel: wp.Kernel, device: wp.context.Device, inputs: Sequence[Any], tail: int = 0) -> None:
        """Pack ``inputs`` and ``tail`` trailing int32 inputs of ``kernel`` (loaded on CPU
        ``device``) for calls of one launch item."""
        block = PackedKernel.pack(kernel, device, inputs, tail)
        self._block = block
        self._forward = self._FORWARD(block.forward)
        self._bounds = ctypes.byref(block._owner.params[0])  # (the recorded launch's, one item)
        self._args = ctypes.byref(block.args)
        self._tail = [ctypes.c_int32.from_buffer(block.args, offset) for offset in block.offsets]

    def __call__(self, *tail: int) -> None:
        """Run the launch item with the trailing integers ``tail``."""
        for slot, value in zip(self._tail, tail, strict=True):
            slot.value = value
        self._forward(self._bounds, self._args)


def _value_fingerprint(value: Any) -> Any:
    """What a packed argument block takes from ``value``: an array's data pointer, shape,
    strides and type; a Warp struct's bytes (its ctypes record, which holds its arrays'
    pointers and shapes and its nested structs); a number's type and value; a vector's
    bytes.  None for anything else (such inputs are packed every time)."""
    if isinstance(value, wp.array):
        return ("array", value.ptr, value.shape, value.strides, value.dtype)
    record = value.__dict__.get("_ctype") if hasattr(value, "__dict__") else None
    if record is not None:
        return ("struct", type(value), bytes(record))
    if isinstance(value, (bool, int, float, np.number)):
        return (type(value), value)
    if wp.types.type_is_scalar(type(value)):  # (a Warp scalar: wp.uint64(id), ...)
        return (type(value), value.value)
    if isinstance(value, ctypes.Array):
        return (type(value), bytes(value))
    return None


def input_fingerprint(inputs: Sequence[Any]) -> tuple | None:
    """A key that changes whenever packing ``inputs`` would give other bytes (None where
    an input is of a kind ``_value_fingerprint`` does not know)."""
    parts = []
    for value in inputs:
        part = _value_fingerprint(value)
        if part is None:
            return None
        parts.append(part)
    return tuple(parts)


class BandPool:
    """``threads - 1`` helper threads in native loops, and the board they share; the
    calling thread is thread 0.  ``run`` posts a pass and takes part in it."""

    def __init__(self, device: wp.context.Device, threads: int, spin_ns: int = SPIN_NS_DEFAULT) -> None:
        """Start ``threads - 1`` helpers on CPU ``device`` (``threads`` <= ``MAX_THREADS``)."""
        if not 1 <= threads <= MAX_THREADS:
            raise ValueError(f"threads {threads} outside 1..{MAX_THREADS}")
        self.device = device
        self.threads = threads
        wp.load_module(_worker_kernel.module, device=device)
        self._board = wp.zeros(BOARD_SIZE, dtype=wp.int64, device=device)
        self._host = self._board.numpy()  # a view of the same memory on the CPU
        self._posting = threading.Lock()
        self._pthreads = _Pthreads()
        self._pthreads.write(self._host)
        self._host[SPIN_NS] = spin_ns
        self._host[CLOCK_WALL] = time.CLOCK_MONOTONIC
        self._host[CLOCK_CPU] = time.CLOCK_THREAD_CPUTIME_ID
        # a pass's fields are written here first (the board's layout), so the native post
        # copies them onto the board after the pass in flight is done (``_RUN_CPP``)
        self._staged = wp.zeros(BOARD_SIZE, dtype=wp.int64, device=device)
        self._staged_host = self._staged.numpy()
        #: What the last ``run`` posted without waiting spent finishing the pass in flight
        #: first (seconds, its own post's microseconds included; 0 where none was).
        self.finished_s = 0.0
        self._run = DirectLaunch(_run_kernel, device, [self._board, self._staged], tail=3)
        self._join = DirectLaunch(_join_kernel, device, [self._board])
        #: The pass posted without waiting (its argument blocks and band table, held until
        #: it is joined), or None.
        self._in_flight: tuple[Sequence[Sequence[PackedKernel]], np.ndarray] | None = None
        run_quit = wp.launch(_quit_kernel, dim=1, inputs=[self._board], device=device, record_cmd=True)
        self._wake = DirectLaunch(_wake_kernel, device, [self._board])
        helpers = [
            threading.Thread(
                target=wp.launch,
                args=(_worker_kernel,),
                kwargs={"dim": 1, "inputs": [self._board, slot], "device": device},
                name=f"warp-hybrid-band-{slot}",
                daemon=True,
            )
            for slot in range(1, threads)
        ]
        for thread in helpers:
            thread.start()
        self._stop = weakref.finalize(self, _stop, run_quit, helpers, (self._board, self._pthreads))

    def close(self) -> None:
        """Finish the pass in flight, if any, and stop the helper threads (idempotent)."""
        if self._stop.alive:
            self.join()
        self._stop()

    def __enter__(self) -> BandPool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def sleepers(self) -> int:
        """How many helper threads sleep now (the others spin or run bands)."""
        return int(self._host[SLEEPERS])

    def wake(self) -> None:
        """Wake the sleeping helper threads now, to spin until the next pass (for
        ``SPIN_NS``): a caller about to post passes after a long idle (a frame after the
        loop's wait for its time) calls it before its own work ahead of them, which the
        helpers' wake-up (40-160 us on a virtual machine) then overlaps instead of
        delaying the first pass.  Nothing where none sleeps."""
        if self._host[SLEEPERS] > 0:
            self._host[NAP] = 0
            self._wake()

    def nap(self) -> None:
        """Let the helper threads sleep now instead of spinning until the next pass (the
        cores go to other work: Python threads running a pass's pieces)."""
        self._host[NAP] = 1

    def run(
        self,
        stages: Sequence[Sequence[PackedKernel]],
        bands: np.ndarray,
        timed: bool = False,
        deadline_ns: int | None = None,
        wait: bool = True,
    ) -> int:
        """Run one pass and return how many of its bands ran (all, or those before the first
        refused by the deadline), after the pass in flight, if any, is done (the native
        post finishes it first; ``finished_s``).  Without ``wait`` (a pass with no
        deadline) only post it and return its band count: the helpers run it while the
        caller goes on, and ``join`` (or the next ``run``) takes part in what is left and
        waits for it; ``stages`` and ``bands`` are held
        until then, and nothing the pass reads or writes (its band times included) may be
        touched before.  Band k runs each stage s in order: ``forward`` of stage
        s's kernel with the thread's argument block ``stages[s][slot]`` (one per thread),
        its trailing integers set from ``bands[k, s * STAGE_COLUMNS + 2:][:tail]``, over
        launch dimension ``bands[k, s * STAGE_COLUMNS:][:2]``.  ``bands`` is a C-contiguous
        int64 (count, ``BAND_COLUMNS``) array; each band run gets the thread that ran it
        (``COL_SLOT``) and, with ``timed`` or a deadline, each stage's wall and thread CPU
        time.  ``deadline_ns`` (``time.CLOCK_MONOTONIC``, None: none): before each band
        whose ``COL_MUST`` is 0, the pass stops there if now plus its ``COL_ITEMS`` at the
        mean wall time an item of the bands done so far is past the deadline."""
        count = bands.shape[0]
        if count == 0:
            return 0
        if count > MAX_BANDS or not 1 <= len(stages) <= MAX_STAGES or any(len(s) != self.threads for s in stages):
            raise ValueError(f"{count} bands of {len(stages)} stages for {self.threads} threads")
        if bands.shape[1] != BAND_COLUMNS or bands.dtype != np.int64 or not bands.flags.c_contiguous:
            raise ValueError("the band table must be a C-contiguous int64 (bands, BAND_COLUMNS) array")
        if not wait and deadline_ns is not None:
            raise ValueError("a pass with a deadline cannot be posted without waiting for it")
        with self._posting:  # one pass on the board at a time
            self._stage(stages, bands, timed, deadline_ns)  # (while the pass in flight runs)
            finishing = self._in_flight  # (held until it is done)
            self._in_flight = None if wait else (stages, bands)
            start = time.perf_counter()
            self._run(count, int(finishing is not None), int(wait))
            self.finished_s = time.perf_counter() - start if finishing is not None and not wait else 0.0
            return int(self._host[RAN]) if wait else count

    @property
    def in_flight(self) -> bool:
        """Whether a pass posted without waiting may still be running (until ``join``)."""
        return self._in_flight is not None

    def join(self) -> float:
        """Take part in the pass in flight and wait until it is done; the seconds this
        waited (0 where none was in flight)."""
        if self._in_flight is None:
            return 0.0
        with self._posting:
            start = time.perf_counter()
            if self._in_flight is not None:  # (another thread may have joined it meanwhile)
                self._join()
                self._in_flight = None
            return time.perf_counter() - start

    def _stage(
        self, stages: Sequence[Sequence[PackedKernel]], bands: np.ndarray, timed: bool, deadline_ns: int | None
    ) -> None:
        """Write the pass's fields beside the board (``_staged``, the board's layout),
        where the native post takes them from (``run``)."""
        host = self._staged_host
        host[STAGES] = len(stages)
        for s, blocks in enumerate(stages):
            offsets = blocks[0].offsets
            host[FN + s] = blocks[0].forward
            host[TAILS + s] = len(offsets)
            host[TAIL_OFFSETS + s * MAX_TAIL : TAIL_OFFSETS + s * MAX_TAIL + len(offsets)] = offsets
            host[ARGS + s * MAX_THREADS : ARGS + s * MAX_THREADS + len(blocks)] = [block.address for block in blocks]
        host[BANDS] = bands.ctypes.data
        host[TIMED] = int(timed)
        host[DEADLINE_NS] = NO_DEADLINE if deadline_ns is None else min(int(deadline_ns), NO_DEADLINE)


def probe_pool(pool: BandPool) -> bool:
    """Whether ``pool`` runs a pass as Warp would: a two-dimensional kernel over two bands
    of different shapes, each with its own trailing integers, writes exactly what
    ``wp.launch`` would (a check of Warp's CPU entry point and argument packing, which
    ``layout_matches`` cannot see)."""
    out = wp.full((3, 4), -1, dtype=wp.int32, device=pool.device)
    wp.load_module(_probe_kernel.module, device=pool.device)
    block = PackedKernel.pack(_probe_kernel, pool.device, [out], 2)
    bands = np.zeros((2, BAND_COLUMNS), dtype=np.int64)
    bands[0, :4] = (2, 4, 0, 7)
    bands[1, :4] = (1, 3, 2, 900)
    ran = pool.run([[block, *(block.copy() for _ in range(1, pool.threads))]], bands)
    expected = np.full((3, 4), -1, np.int32)
    expected[:2] = 7 + 10 * np.arange(2)[:, None] + np.arange(4)[None, :]
    expected[2, :3] = 900 + np.arange(3)
    return ran == 2 and np.array_equal(out.numpy(), expected)


def native_band_pool(device: wp.context.Device, threads: int) -> BandPool | None:
    """Native band threads for ``threads`` threads on ``device``: None on CUDA, on one
    thread, beyond ``MAX_THREADS``, or where ``layout_matches`` or ``probe_pool`` fails
    (with a warning: this Warp packs or calls kernels otherwise; the caller then uses
    Python threads)."""
    if device.is_cuda or not 1 < threads <= MAX_THREADS or not layout_matches():
        return None
    pool = BandPool(device, threads)
    if not probe_pool(pool):
        pool.close()
        warnings.warn(
            f"warp-hybrid: native band threads disabled (Warp {wp.config.version} ran the probe pass otherwise); "
            "passes run on Python threads",
            RuntimeWarning,
            stacklevel=2,
        )
        return None
    return pool
