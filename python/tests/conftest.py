"""The plugin under test is not listed here: it must load through its ``pytest11``
entry point, as it does for users (so these tests need the package installed)."""

pytest_plugins = ["pytester"]
