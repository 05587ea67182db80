"""Evaluation against the ground truth: truth files, predictions, component and body scores, the report."""
