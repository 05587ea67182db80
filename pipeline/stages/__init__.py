"""The seven stages of one abstraction pass, each a function over the current kinematic tree.

Identification, attachment root detection, pre-classification, group merging, verification,
post-classification and sub-part classification ask the model constrained questions through an
Oracle; verification is deterministic. pipeline.abstraction runs them for each component kind.
"""
