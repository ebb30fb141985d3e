VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: test demo docs lint bench clean compiled pure

# The core compiled by mypyc (setup.py, WISWARM_MYPYC=1): opt-in in place (`make
# compiled`, undone by `make pure`); `make test` also runs the core's tests on a
# compiled copy of the tree, so that both builds are held to the same tests.
COMPILED_COPY := build/compiled
CORE_SO := wiswarm_zenoh/core/*.so

$(STAMP): pyproject.toml
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip 'setuptools>=77'
	$(PY) -m pip install -q -e '.[test]'
	touch $(STAMP)

test: $(STAMP) $(COMPILED_COPY)/.built
	$(PY) -m ruff check wiswarm_zenoh apps tests benchmarks examples
	$(PY) -m mypy --strict wiswarm_zenoh apps examples
	$(PY) -m pytest
	cd $(COMPILED_COPY) && WISWARM_CORE_BUILD=compiled $(abspath $(PY)) -m pytest -p no:cacheprovider tests/core

$(COMPILED_COPY)/.built: $(STAMP) setup.py $(wildcard wiswarm_zenoh/core/*.py tests/core/*.py)
	rm -rf $(COMPILED_COPY) && mkdir -p $(COMPILED_COPY)/tests
	cp -r wiswarm_zenoh setup.py pyproject.toml README.md $(COMPILED_COPY)/
	cp -r tests/core $(COMPILED_COPY)/tests/
	rm -f $(COMPILED_COPY)/$(CORE_SO)
	cd $(COMPILED_COPY) && WISWARM_MYPYC=1 $(abspath $(PY)) setup.py -q build_ext --inplace \
		>build.log 2>&1 || (tail -20 build.log; exit 1)
	touch $@

compiled: $(STAMP)
	mkdir -p build
	WISWARM_MYPYC=1 $(PY) setup.py -q build_ext --inplace >build/mypyc.log 2>&1 \
		|| (tail -20 build/mypyc.log; exit 1)

pure:
	rm -f $(CORE_SO)

demo: $(STAMP)
	$(VENV)/bin/wiswarm demo

docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --site-dir site

bench: $(STAMP)
	$(PY) benchmarks/bench_policies.py

clean:
	rm -rf $(VENV) .mypy_cache .pytest_cache .ruff_cache site build $(CORE_SO)
