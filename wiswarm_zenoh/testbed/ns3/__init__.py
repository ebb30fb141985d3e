"""The ns-3 scenario behind ``--medium wifi`` (C++ source, built on first use)."""
