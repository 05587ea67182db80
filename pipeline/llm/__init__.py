"""Model layer: the backend contract and its implementations (imported from their own modules)."""
from urdfkb.pipeline.llm.base import Backend, Question, Stats

__all__ = ["Backend", "Question", "Stats"]
