VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: test demo docs lint bench clean

$(STAMP): pyproject.toml
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	touch $(STAMP)

test: $(STAMP)
	$(PY) -m ruff check wiswarm_zenoh apps tests benchmarks
	$(PY) -m mypy --strict wiswarm_zenoh apps
	$(PY) -m pytest

demo: $(STAMP)
	$(VENV)/bin/wiswarm demo

docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --site-dir site

bench: $(STAMP)
	$(PY) benchmarks/bench_policies.py

clean:
	rm -rf $(VENV) .mypy_cache .pytest_cache .ruff_cache site
