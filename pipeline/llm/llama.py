"""Embedded llama.cpp backend: whole-option scoring with a KV-cached shared prefix and batched decodes."""
from __future__ import annotations

import ctypes
import logging
import os
import random
import struct
from pathlib import Path
from typing import Sequence

from urdfkb.pipeline.errors import BackendError
from urdfkb.pipeline.llm.base import Backend, Question, Stats
from urdfkb.pipeline.llm.llama_process import choose_openmp_waiting, load_model
from urdfkb.pipeline.llm.option_trie import OptionJob, RowLogprobs, common_prefix, draw, unique_length
from urdfkb.pipeline.llm.prefix_store import PrefixStore, default_dir, enabled_by_env
from urdfkb.settings import PREFIX_CACHE_BYTES

log = logging.getLogger(__name__)

SENTINEL = "\x00URDFKB\x00"
PREFIX = 0  # the KV sequence holding the system prefix; options are sequences 1..
# context parameters that change a stored prefix state's bytes or its numerics
_STATE_PARAMS = ("n_ctx", "n_batch", "n_ubatch", "n_seq_max", "n_threads", "n_threads_batch", "kv_unified",
                 "flash_attn_type", "type_k", "type_v", "swa_full", "offload_kqv")


class LlamaBackend(Backend):
    """llama-cpp-python in process; scores every option of many questions in few decodes.

    Prompts are rendered with the GGUF's own chat template. The system part (everything before the
    user text) is evaluated once into sequence 0 of the KV cache and shared by every question with
    that system text; each option is a sequence sharing that prefix, and the questions of one decode
    share their user texts' common leading tokens. A new system text empties the cache first and
    starts again at cell 0, so a prefix always lands in the same cells next to nothing else: its state
    is a function of its tokens alone, which the on-disk store (prefix_store) keeps and restores
    exactly, and every score is a function of its question and its batch, not of what was asked before.
    Not thread-safe: use one backend per thread.
    """

    exposes_logits = True

    def __init__(self, model_path: str | Path, n_ctx: int = 4096, n_threads: int | None = None, seed: int = 0,
                 n_batch: int = 512, n_seq_max: int = 64, prefix_cache: bool | str | Path = True,
                 prefix_cache_bytes: int = PREFIX_CACHE_BYTES,
                 flash_attn: bool = False, kv_type: str = "f16"):
        choose_openmp_waiting()
        import llama_cpp
        from llama_cpp import _internals

        self._lib = llama_cpp
        path = Path(model_path)
        self.name = f"llama.cpp:{path.name}"
        self.stats = Stats()
        self.seed = seed
        self._draws = 0
        threads = n_threads or os.cpu_count() or 1
        try:
            self._model = load_model(path)
            self._params = self._context_params(n_ctx, n_batch, n_seq_max, threads, flash_attn, kv_type)
            self._ctx = _internals.LlamaContext(model=self._model, verbose=False, params=self._params)
        except Exception as exc:
            raise BackendError(f"{self.name}: cannot load {path}: {exc}") from exc
        self.n_ctx, self.n_batch = n_ctx, n_batch
        self.n_seq_max = llama_cpp.llama_n_seq_max(self._ctx.ctx)
        self._batch = _internals.LlamaBatch(n_tokens=n_batch, embd=0, n_seq_max=self.n_seq_max, verbose=False)
        self.n_vocab = self._model.n_vocab()
        self._formatter = self._chat_formatter()
        self.eot = self._end_of_turn()
        self._prefix: list[int] = []  # the tokens sequence PREFIX holds, in cells 0..len-1
        self._store = self._prefix_store(path, prefix_cache, prefix_cache_bytes, threads)

    def _context_params(self, n_ctx: int, n_batch: int, n_seq_max: int, threads: int, flash_attn: bool, kv_type: str):
        """Flash attention and a quantized KV cache (`kv_type` "q8_0") change scores, and so answers: they
        exist to be measured (benchmarks.llama_settings_bench), and are off by default."""
        params = self._lib.llama_context_default_params()
        params.n_ctx, params.n_batch, params.n_ubatch = n_ctx, n_batch, n_batch
        params.n_seq_max = min(n_seq_max, self._lib.llama_max_parallel_sequences())
        params.n_threads = params.n_threads_batch = threads
        params.kv_unified = True  # one cache where a cell can belong to several sequences
        params.flash_attn_type = (self._lib.LLAMA_FLASH_ATTN_TYPE_ENABLED if flash_attn
                                  else self._lib.LLAMA_FLASH_ATTN_TYPE_DISABLED)  # disabled: same numerics as Llama()
        params.type_k = params.type_v = {"f16": self._lib.GGML_TYPE_F16, "q8_0": self._lib.GGML_TYPE_Q8_0}[kv_type]
        params.no_perf = True
        return params

    def _prefix_store(self, model: Path, where: bool | str | Path, max_bytes: int, threads: int) -> PrefixStore | None:
        """The on-disk store of prefix KV states: `where` is a directory, True for the default one
        unless $URDFKB_PREFIX_CACHE is off (it is on by default), False for none. Its identity is everything that changes
        the stored bytes: the model file, the llama.cpp build and the context parameters."""
        if where is False or (where is True and not enabled_by_env()):
            return None
        if self._lib.llama_model_n_swa(self._model.model) > 0:
            return None  # a sliding-window cache prunes cells as it evaluates: untested here, so not stored
        lib = Path(self._lib.llama_cpp._lib._name)
        identity = {
            "model": _file_identity(model),
            "llama_cpp": [self._lib.__version__, _file_identity(lib)],
            "context": {name: getattr(self._params, name) for name in _STATE_PARAMS},
        }
        return PrefixStore(default_dir() if where is True else Path(where), identity, max_bytes)

    # --- prompt rendering -------------------------------------------------------------------

    def _chat_formatter(self):
        from llama_cpp.llama_chat_format import Jinja2ChatFormatter

        template = self._model.metadata().get("tokenizer.chat_template")
        if not template:
            raise BackendError(f"{self.name}: the GGUF has no chat template")
        model = self._model
        bos, eos = model.token_bos(), model.token_eos()
        return Jinja2ChatFormatter(template, eos_token=model.token_get_text(eos) if eos >= 0 else "",
                                   bos_token=model.token_get_text(bos) if bos >= 0 else "")

    def _render(self, system: str, user: str, answer: str | None = None) -> str:
        messages = [{"role": "system", "content": system}, {"role": "user", "content": user}]
        if answer is not None:
            messages.append({"role": "assistant", "content": answer})
        return self._formatter(messages=messages).prompt

    def _tokens(self, text: str) -> list[int]:
        """Tokens of rendered text (special tokens parsed), with the model's BOS if it wants one."""
        tokens = self._model.tokenize(text.encode("utf-8"), add_bos=False, special=True)
        bos = self._model.token_bos()
        if self._model.add_bos_token() and bos >= 0 and tokens[:1] != [bos]:
            tokens = [bos] + tokens
        return tokens

    def _end_of_turn(self) -> int:
        """The token the template puts after an assistant answer (if end-of-generation), else EOT/EOS."""
        text = self._render("s", "u", SENTINEL)
        after = text[text.index(SENTINEL) + len(SENTINEL):]
        vocab = self._model.vocab
        first = self._model.tokenize(after.encode("utf-8"), add_bos=False, special=True)[:1]
        if first and self._lib.llama_vocab_is_eog(vocab, first[0]):
            return first[0]
        eot = self._lib.llama_vocab_eot(vocab)
        return eot if eot >= 0 else self._model.token_eos()

    def prompt_tokens(self, question: Question) -> list[int]:
        """The full prompt: system, user and generation prompt, in the model's chat template."""
        return self._tokens(self._render(question.system, question.user))

    def option_tokens(self, option: str) -> list[int]:
        """An option's continuation (its text tokens) without the end-of-turn token."""
        return self._model.tokenize(option.encode("utf-8"), add_bos=False, special=False)

    def prefix_tokens(self, system: str) -> list[int]:
        """The rendered prompt up to where the user text starts: what questions with this system text share."""
        text = self._render(system, SENTINEL)
        return self._tokens(text[: text.index(SENTINEL)])

    # --- scoring ----------------------------------------------------------------------------

    def score(self, questions: Sequence[Question]) -> list[list[float]]:
        """Whole-option log-probabilities; questions sharing a system text share one cached prefix."""
        results: dict[int, list[float]] = {}
        by_system: dict[str, list[int]] = {}
        for i, q in enumerate(questions):
            by_system.setdefault(q.system, []).append(i)
        try:
            for system, indices in by_system.items():
                self._score_group(system, [questions[i] for i in indices], indices, results)
        except BackendError:
            raise
        except Exception as exc:
            self.reset()
            raise BackendError(f"{self.name}: scoring failed: {type(exc).__name__}: {exc}") from exc
        return [results[i] for i in range(len(questions))]

    def _score_group(self, system: str, questions: list[Question], indices: list[int], out: dict) -> None:
        prefix = self.prefix_tokens(system)
        prompts = [self.prompt_tokens(q) for q in questions]
        # the shared part: the rendered system prefix, as tokenized inside every full prompt, minus
        # at least the last prompt token (decoded per question to predict the first answer token)
        shared = min(min(common_prefix(prefix, p), len(p) - 1) for p in prompts)
        jobs = [self._job(q, p, shared) for q, p in zip(questions, prompts)]
        self._load_prefix(prefix[:shared])
        for chunk in self._chunks(list(zip(indices, jobs)), self.n_ctx - shared):
            for i, scores in zip([i for i, _ in chunk], self._decode_jobs([j for _, j in chunk], shared)):
                out[i] = scores

    def _job(self, question: Question, prompt: list[int], shared: int) -> OptionJob:
        options = [self.option_tokens(o) for o in question.options]
        if question.until_unique:
            options = [o[:unique_length(o, options)] for o in options]
        job = OptionJob(prompt[shared:], options)
        if (len(options) > self.n_seq_max - 1 or job.size > self.n_batch
                or len(prompt) + max(map(len, options)) > self.n_ctx):
            raise BackendError(f"{self.name}: question {question.key!r} does not fit one decode "
                               f"({job.size} tokens, {len(options)} options; n_batch {self.n_batch}, "
                               f"n_seq_max {self.n_seq_max}, n_ctx {self.n_ctx})")
        return job

    def _chunks(self, jobs: list, free_cells: int):
        """Greedy groups of jobs that fit one decode: tokens, sequences and free cache cells (counting
        each job's tokens in full, though jobs sharing leading suffix tokens take fewer)."""
        chunk: list = []
        tokens, seqs = 0, 1
        for item in jobs:
            job = item[1]
            fits = (tokens + job.size <= min(self.n_batch, free_cells)
                    and seqs + len(job.options) <= self.n_seq_max)
            if chunk and not fits:
                yield chunk
                chunk, tokens, seqs = [], 0, 1
            chunk.append(item)
            tokens, seqs = tokens + job.size, seqs + len(job.options)
        if chunk:
            yield chunk

    def _load_prefix(self, prefix: list[int]) -> None:
        """Make sequence PREFIX hold exactly `prefix`, in cells 0..len-1 of an otherwise empty cache.

        Kept if it already does; otherwise the cache is emptied and the prefix restored from the
        on-disk store, or evaluated (and stored). Starting from an empty cache every time costs the
        tokens a new system text shares with the last one (the common preamble), and buys states
        that are the same wherever they are needed: in this run, the next, or another robot's.
        """
        if self._prefix == prefix:
            return
        self.reset()
        if self._store is not None and self._restore(prefix):
            return
        for start in range(0, len(prefix), self.n_batch):
            piece = prefix[start: start + self.n_batch]
            self._fill([(t, start + k, (PREFIX,), False) for k, t in enumerate(piece)])
            self._decode()
        self._prefix = list(prefix)
        if self._store is not None:
            self._save(prefix)

    # --- the on-disk store of prefix states ---------------------------------------------------
    # llama.cpp's CPU kernels are exact functions of the cells a token attends over: the same values in
    # the same cells give bit-identical scores, other cells other roundings. A prefix is evaluated into
    # an emptied cache, in n_batch pieces from cell 0; a restore into the emptied cache places its cells
    # as one ubatch from cell 0. Both fill cells 0..len-1 with the same bytes, so a restore leaves the
    # cache as evaluating would, and every later score is bit-identical to a run without the store.

    @property
    def _stored(self) -> PrefixStore:
        """The prompt-state store, for the steps that run only with one."""
        if self._store is None:
            raise RuntimeError(f"{self.name}: no prompt-state store")
        return self._store

    def _restore(self, prefix: list[int]) -> bool:
        """Fill the emptied cache's sequence PREFIX with the stored state of `prefix`; False, with the
        cache empty again, when there is none or it cannot be used."""
        if (payload := self._stored.load(prefix)) is None:
            return False
        if (held := _state_positions(payload)) != list(range(len(prefix))):
            self._stored.discard(prefix, f"holds positions {held[:1]}..{held[-1:]}")
            return False
        buf = (ctypes.c_uint8 * len(payload)).from_buffer(payload)
        if not self._lib.llama_state_seq_set_data(self._ctx.ctx, buf, len(payload), PREFIX):
            self._stored.discard(prefix, "llama.cpp refused it")
            self.reset()  # llama.cpp may have placed cells and freed them again: start from empty
            return False
        self._prefix = list(prefix)
        self.stats.restored_tokens += len(prefix)
        return True

    def _save(self, prefix: list[int]) -> None:
        """Store the state of sequence PREFIX (it holds exactly `prefix`, and the cache nothing else)."""
        size = self._lib.llama_state_seq_get_size(self._ctx.ctx, PREFIX)
        buf = (ctypes.c_uint8 * size)()
        written = self._lib.llama_state_seq_get_data(self._ctx.ctx, buf, size, PREFIX)
        if written:
            self._stored.save(prefix, memoryview(buf)[:written])

    # --- decoding ------------------------------------------------------------------------------

    def _decode_jobs(self, jobs: list[OptionJob], n_prefix: int) -> list[list[float]]:
        """Whole-option log-probabilities of every job, from one decode."""
        logprobs, wanted = self._decode_rows(jobs, n_prefix)
        return [[self._option_logprob(logprobs, r, o) for r, o in zip(rows, job.options)]
                for rows, job in zip(wanted, jobs)]

    def _decode_rows(self, jobs: list[OptionJob], n_prefix: int) -> tuple[RowLogprobs, list[list[list[tuple[int, int]]]]]:
        """One decode for all options of all jobs; returns the row reader and, per job and option, its
        scored steps (OptionJob.steps), each with the batch row predicting it.

        Every option is a sequence copying the prefix from sequence PREFIX. The jobs' suffixes are laid
        out as one token trie (a suffix token is evaluated once for all jobs that share the tokens up to
        it, as siblings' texts often begin alike), and each job's options as a trie after its suffix.
        """
        seqs_of: list[tuple[int, ...]] = []
        suffix_seqs: dict[tuple[int, ...], list[int]] = {}  # a suffix trie node -> the sequences through it
        seq = PREFIX + 1
        for job in jobs:
            seqs = tuple(range(seq, seq + len(job.options)))
            seq += len(job.options)
            seqs_of.append(seqs)
            for k in range(1, len(job.suffix) + 1):
                suffix_seqs.setdefault(tuple(job.suffix[:k]), []).extend(seqs)
        for s in range(PREFIX + 1, seq):
            self._seq_cp(PREFIX, s)
        ends = {tuple(job.suffix) for job in jobs}
        entries: list[tuple[int, int, tuple[int, ...], bool]] = []
        row_of_suffix: dict[tuple[int, ...], int] = {}
        for node, members in suffix_seqs.items():  # a node always after its parent
            row_of_suffix[node] = len(entries)
            entries.append((node[-1], n_prefix + len(node) - 1, tuple(members), node in ends))
        wanted = []
        for job, seqs in zip(jobs, seqs_of):
            base = n_prefix + len(job.suffix)
            row_of: dict[tuple[int, ...], int] = {(): row_of_suffix[tuple(job.suffix)]}
            for prefix, members in job.trie().items():
                row_of[prefix] = len(entries)
                entries.append((prefix[-1], base + len(prefix) - 1, tuple(seqs[i] for i in members), True))
            wanted.append([[(k, row_of[tuple(option[:k])]) for k in job.steps(option)] for option in job.options])
        try:
            self._fill(entries)
            self._decode()
            return RowLogprobs(self._lib, self._ctx.ctx, self.n_vocab), wanted
        finally:
            for s in range(PREFIX + 1, seq):
                self._seq_rm(s)

    def _option_logprob(self, logprobs: RowLogprobs, rows: list[tuple[int, int]], option: list[int]) -> float:
        """Sum of log P(target | before) over the option's scored steps (OptionJob.steps)."""
        targets = option + [self.eot]
        return float(sum(logprobs(row, targets[k]) for k, row in rows))

    def _seq_rm(self, seq: int) -> None:
        self._lib.llama_memory_seq_rm(self._ctx.memory, seq, -1, -1)

    def _seq_cp(self, src: int, dst: int) -> None:
        self._lib.llama_memory_seq_cp(self._ctx.memory, src, dst, -1, -1)

    def _fill(self, entries: list[tuple[int, int, tuple[int, ...], bool]]) -> None:
        """Write (token, position, sequence ids, wants logits) entries into the batch."""
        b = self._batch.batch
        for i, (token, pos, seqs, logits) in enumerate(entries):
            b.token[i], b.pos[i], b.n_seq_id[i], b.logits[i] = token, pos, len(seqs), logits
            for k, s in enumerate(seqs):
                b.seq_id[i][k] = s
        b.n_tokens = len(entries)

    def _decode(self) -> None:
        """Decode the filled batch (one ubatch: it never exceeds n_batch = n_ubatch)."""
        n = self._batch.batch.n_tokens
        code = self._lib.llama_decode(self._ctx.ctx, self._batch.batch)
        self.stats.calls += 1
        if code != 0:
            self.reset()
            raise BackendError(f"{self.name}: llama_decode returned {code} for {n} tokens")
        self.stats.prompt_tokens += n

    def reset(self) -> None:
        """Forget every cached token (the next question evaluates or restores its system prefix)."""
        self._lib.llama_memory_clear(self._ctx.memory, True)
        self._prefix = []

    def fresh(self) -> None:
        """As just loaded: an empty KV cache (zeroed), the sampling draws and the counters."""
        super().fresh()
        self.reset()
        self._draws = 0

    # --- sampling ---------------------------------------------------------------------------

    def sample(self, question: Question, n: int, temperature: float) -> list[str]:
        """n answers drawn token by token at `temperature`, each step restricted to the tokens that
        continue some option (the option trie, as a grammar would constrain it).

        The rows every step needs are those scoring already computes, so all n draws come from one
        decode. Within one row a tempered softmax over the allowed tokens is the same from logits
        or from log-probabilities (they differ by a constant), so draws read the log-probabilities.
        """
        try:
            prefix, prompt = self.prefix_tokens(question.system), self.prompt_tokens(question)
            shared = min(common_prefix(prefix, prompt), len(prompt) - 1)
            job = self._job(question, prompt, shared)
            self._load_prefix(prefix[:shared])
            logprobs, (rows,) = self._decode_rows([job], shared)
            targets = [option + [self.eot] for option in job.options]
            return [question.options[self._draw(targets, rows, logprobs, temperature)] for _ in range(n)]
        except BackendError:
            raise
        except Exception as exc:
            self.reset()
            raise BackendError(f"{self.name}: sampling failed: {type(exc).__name__}: {exc}") from exc

    def _draw(self, targets: list[list[int]], rows: list[list[tuple[int, int]]], logprobs: RowLogprobs,
              temperature: float) -> int:
        """One draw (option_trie.draw), each from its own generator: the backend's seed and the draw's number."""
        self._draws += 1
        pick = draw(targets, rows, logprobs, temperature, random.Random(self.seed * 1_000_003 + self._draws))
        self.stats.generated_tokens += len(targets[pick]) - 1
        return pick

    def close(self) -> None:
        """Free the scoring context, the batch and the model."""
        self._batch.close()
        self._ctx.close()
        self._model.close()


def _state_positions(payload: memoryview | bytes) -> list[int]:
    """The positions a llama_state_seq_get_data payload holds (one stream, one sequence per cell, no cell
    extras: what this backend writes), read from its header; [] if it is not such a payload."""
    try:
        magic, _, n_stream, count = struct.unpack_from("<IiII", payload, 0)  # llama-context.cpp io_magic
        if magic != 0xAF143CD8 or n_stream != 1:
            return []
        entry = struct.Struct("<iIi")  # position, n_seq_id (1), sequence id
        found = []
        for i in range(count):
            pos, n_seq, _ = entry.unpack_from(payload, 16 + i * entry.size)
            if n_seq != 1:
                return []
            found.append(pos)
        return found
    except struct.error:
        return []


def _file_identity(path: Path) -> list:
    """Cheap identity of a file: resolved path, size and modification time."""
    st = path.stat()
    return [str(path.resolve()), st.st_size, st.st_mtime_ns]
