"""Abstraction: the passes and their steps, structure read from the tree, prompts, the product catalogue."""
