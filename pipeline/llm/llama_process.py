"""llama.cpp in this process: how its threads wait (OpenMP), the backend initialised once, and a model loaded
alone with the parameters that work on this processor."""
from __future__ import annotations

import functools
import os
import time
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # llama_cpp is imported only once the OpenMP wait policy is chosen
    from llama_cpp import llama_model_params
    from llama_cpp._internals import LlamaModel

_BACKEND_READY = False
BUSY_ELSEWHERE = 0.5  # cores other processes keep busy from which llama.cpp's threads wait passively


def choose_openmp_waiting(window: float = 0.25) -> None:
    """Set OMP_WAIT_POLICY=PASSIVE when other processes keep at least BUSY_ELSEWHERE of a core busy.

    llama.cpp's threads meet at an OpenMP barrier after every operation of a decode, where libgomp spins
    before it sleeps. On cores shared with busy processes a spinning thread burns the slice its partner
    needs; with the cores to itself, waking a sleeping thread costs more than the spin (docs/speed.md,
    "llama.cpp settings"). Scores are bit-identical either way.
    The busy share is sampled from /proc/stat over `window` seconds, less this process's own time;
    libgomp reads the policy once, when llama_cpp loads it, so a process keeps its first choice. An
    OMP_WAIT_POLICY or GOMP_SPINCOUNT already set is left alone."""
    if "OMP_WAIT_POLICY" in os.environ or "GOMP_SPINCOUNT" in os.environ:
        return
    try:
        before, mine = _cpu_ticks(), os.times()
        time.sleep(window)
        after, mine_after = _cpu_ticks(), os.times()
    except (OSError, ValueError, IndexError):
        return
    total, idle = after[0] - before[0], after[1] - before[1]
    own = (mine_after.user + mine_after.system - mine.user - mine.system) * os.sysconf("SC_CLK_TCK")
    cores = os.cpu_count() or 1
    if total > 0 and (total - idle - own) / total * cores >= BUSY_ELSEWHERE:
        os.environ["OMP_WAIT_POLICY"] = "PASSIVE"


def _cpu_ticks() -> tuple[int, int]:
    """All CPUs' ticks since boot, and their idle (and I/O wait) ticks, from /proc/stat."""
    with open("/proc/stat") as f:
        fields = [int(x) for x in f.readline().split()[1:9]]
    return sum(fields), fields[3] + fields[4]


def load_model(path: Path) -> LlamaModel:
    """The model alone, with the parameters llama_cpp.Llama would give it (CPU, memory-mapped). Llama itself
    would also build a context of its own, with a KV cache and compute buffers, that scoring never uses."""
    import llama_cpp
    from llama_cpp import _internals

    global _BACKEND_READY
    if not _BACKEND_READY:
        from llama_cpp._logger import set_verbose

        set_verbose(False)  # llama.cpp's log: errors only, as Llama(verbose=False) sets it
        llama_cpp.llama_backend_init()
        _BACKEND_READY = True
    params = without_amx_buffers(llama_cpp.llama_model_default_params())
    params.n_gpu_layers, params.split_mode, params.main_gpu = 0, llama_cpp.LLAMA_SPLIT_MODE_LAYER, 0
    params.vocab_only = False
    params.load_mode = llama_cpp.LLAMA_LOAD_MODE_MMAP
    return _internals.LlamaModel(path_model=str(path), params=params, verbose=False)


def without_amx_buffers(params: llama_model_params) -> llama_model_params:
    """llama.cpp model parameters `params`, less the extra weight buffers on a processor with AMX: the AMX
    matrix kernel of llama-cpp-python 0.3.36 (built natively) segfaults in its first batched decode
    (ggml_backend_amx_mul_mat), and without the extra buffers the weights stay in the ordinary CPU buffer,
    whose kernels answer (docs/speed.md, "llama.cpp settings")."""
    if cpu_has_amx():
        params.use_extra_bufts = False
    return params


@functools.cache
def cpu_has_amx() -> bool:
    """The processor offers AMX tiles (Linux /proc/cpuinfo flags; False where that cannot be read)."""
    try:
        with open("/proc/cpuinfo") as f:
            flags = next((line for line in f if line.startswith("flags")), "")
    except OSError:
        return False
    return "amx_tile" in flags.split()
