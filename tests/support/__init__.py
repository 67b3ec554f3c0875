"""Helpers shared by the tests (imported as ``tests.support.<module>``; conftest.py holds the fixtures)."""
