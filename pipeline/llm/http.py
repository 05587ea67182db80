"""OpenAI-compatible chat backend (llama.cpp server, vLLM, Ollama /v1) over stdlib urllib."""
from __future__ import annotations

import json
import socket
from http import HTTPStatus
import urllib.error
import urllib.parse
import urllib.request
from typing import Sequence

from urdfkb.pipeline.errors import BackendError
from urdfkb.pipeline.llm.base import Backend, Question, Stats
from urdfkb.settings import LLM_TIMEOUT, MAX_LLM_REPLY


class OpenAIBackend(Backend):
    """Samples answers from `/v1/chat/completions`; no log-probabilities, so the Oracle votes by sampling.

    Only http(s) URLs are opened, and errors never quote what the server sent (a status and a
    length), so a URL pointed at some other service cannot be used to read it.
    """

    exposes_logits = False

    def __init__(self, base_url: str, model: str, api_key: str | None = None, timeout: float = LLM_TIMEOUT):
        parts = urllib.parse.urlsplit(base_url)
        if parts.scheme not in ("http", "https") or not parts.hostname:
            raise BackendError(f"LLM server URL must be http:// or https:// with a host, not {base_url[:100]!r}")
        base = base_url.rstrip("/")
        self.url = base + ("/chat/completions" if base.endswith("/v1") else "/v1/chat/completions")
        self.name = f"openai:{base_url}:{model}"
        self.model, self.api_key, self.timeout = model, api_key, timeout
        self.stats = Stats()

    def score(self, questions: Sequence[Question]) -> list[list[float]]:
        """Not available: chat completions expose no whole-option log-probabilities."""
        raise BackendError(f"{self.name}: no log-probabilities over HTTP; use vote='sample'")

    def sample(self, question: Question, n: int, temperature: float) -> list[str]:
        """n raw answers; asks for `n` choices at once and tops up one request at a time if the server ignores `n`."""
        texts = self._complete(question, n, temperature)
        while len(texts) < n:
            texts += self._complete(question, 1, temperature)
        return texts[:n]

    def _complete(self, question: Question, n: int, temperature: float) -> list[str]:
        listed = "\n".join(f"- {o}" for o in question.options)
        body = {
            "model": self.model,
            "messages": [
                {"role": "system", "content": question.system},
                {"role": "user", "content": f"{question.user}\n\nAnswer with exactly one of these, nothing else:\n{listed}"},
            ],
            "temperature": temperature,
            "max_tokens": max(len(o) for o in question.options) + 8,
            "n": n,
        }
        reply = self._post(body)
        try:
            texts = [c["message"]["content"] or "" for c in reply["choices"]]
        except (KeyError, TypeError) as exc:
            raise BackendError(f"{self.name}: {self.url} answered JSON without choices[].message.content") from exc
        if not texts:
            raise BackendError(f"{self.name}: no choices in the response from {self.url}")
        usage = reply.get("usage") or {}
        self.stats.prompt_tokens += int(usage.get("prompt_tokens") or 0)
        self.stats.generated_tokens += int(usage.get("completion_tokens") or 0)
        return texts

    def _post(self, body: dict) -> dict:
        headers = {"Content-Type": "application/json"}
        if self.api_key:
            headers["Authorization"] = f"Bearer {self.api_key}"
        request = urllib.request.Request(self.url, data=json.dumps(body).encode(), headers=headers, method="POST")
        self.stats.calls += 1
        try:
            with urllib.request.urlopen(request, timeout=self.timeout) as response:
                raw = response.read(MAX_LLM_REPLY + 1)
        except urllib.error.HTTPError as exc:
            raise BackendError(f"{self.name}: {self.url} answered HTTP {exc.code} {_phrase(exc.code)} "
                               f"(body of {len(exc.read(MAX_LLM_REPLY))} bytes not shown)") from exc
        except (TimeoutError, socket.timeout) as exc:
            raise BackendError(f"{self.name}: {self.url} timed out after {self.timeout}s") from exc
        except (urllib.error.URLError, OSError) as exc:
            raise BackendError(f"{self.name}: cannot reach {self.url}: {getattr(exc, 'reason', exc)}") from exc
        if len(raw) > MAX_LLM_REPLY:
            raise BackendError(f"{self.name}: {self.url} answered more than {MAX_LLM_REPLY} bytes")
        try:
            reply = json.loads(raw)
        except ValueError:
            reply = None
        if not isinstance(reply, dict):
            raise BackendError(f"{self.name}: {self.url} answered {len(raw)} bytes that are not a JSON object")
        return reply


def _phrase(code: int) -> str:
    """The standard reason phrase (the server's own one is its text, not shown)."""
    try:
        return HTTPStatus(code).phrase
    except ValueError:
        return ""
