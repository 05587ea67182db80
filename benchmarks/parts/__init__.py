"""A library of public parts (cameras, lidars, IMUs, force-torque sensors, grippers, hands) as users' URDFs
include them, mounted on generated hosts, with the truth of each resulting robot.

data/<part>.yaml: one part each, written from its public description (source repository, file, commit,
licence and product recorded in it; no meshes or code copied): its frames as the macro generates them,
simple geometry, the simulator sensors it declares, and its truth in the schema of
../shared/spec/evaluation.md. library.py reads and instantiates parts; hosts.py builds the robots that
carry them; `python -m benchmarks.parts` scores the pipeline over parts x hosts.
"""
