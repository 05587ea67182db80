"""The stages of one abstraction pass, each a function over the current kinematic tree.

Numbered as in the README: 1 identification (and, for sensors, sensor_check), 2 attachment root
detection, 3 pre-classification, 4 group merging, 5 verification, 6 post-classification (for
end-effectors: extent and mount by structure, kind by the reasoner, tools), 7 sub-part typing
(subparts). All but verification can ask the model constrained questions through an Oracle;
verification is deterministic. The steps of pipeline.abstraction.steps call them; pipeline.abstraction.abstractor declares
each kind's pass as a list of those steps.
"""
