"""Runs until killed (a busy loop: the sandbox allows no sleep); run by tests/test_xacro_sandbox.py."""
while True:
    pass
