"""The test suite, a package so that tests and benchmarks import its helpers by one name (tests.kb_fixtures)."""
