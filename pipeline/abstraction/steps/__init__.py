"""The abstraction's steps: plain functions over a context (the robot, the model, the vocabulary) and a
findings record, each declaring the fields of the record it reads and makes (pipeline.abstraction.passes.step).

Grouped by what they settle: shape (what the robot's shape says before any question), identify (each
leaf's kind), devices (mounts and groups), classify (device and sub-part classes), tools (the
end-effectors' structure and reasoner), assembly (the components), body (body parts and placement).
pipeline.abstraction.abstractor declares the passes as lists of these steps; pipeline.abstraction.stages holds what they call.
"""
