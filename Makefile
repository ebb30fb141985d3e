VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: test compiled-test demo docs lint bench clean compiled pure

# The core and the transport's poll path compiled by mypyc (setup.py, WISWARM_MYPYC=1):
# opt-in in place (`make compiled`, undone by `make pure`); `make test` also runs the
# core's tests and the poll path's on a compiled copy of the tree, so that both builds
# are held to the same tests.
COMPILED_COPY := build/compiled
CORE_SO := wiswarm_zenoh/core/*.so wiswarm_zenoh/transport/*.so
POLL_PATH_TESTS := tests/transport/__init__.py tests/transport/conftest.py \
	tests/transport/fixtures.py tests/transport/helpers.py tests/transport/test_polling.py \
	tests/transport/test_poll_work.py tests/transport/test_poll_switches.py \
	tests/transport/test_polls_in_flight.py tests/transport/test_never_answering.py \
	tests/transport/test_membership.py tests/transport/test_silence.py
# pytest's workers (pytest-xdist): most tests wait on sessions, processes and links more
# than they compute, so three share the two cores (tests/conftest.py says what runs
# alone); WORKERS=0 runs the suite in this one process.
WORKERS ?= 3

$(STAMP): pyproject.toml
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip 'setuptools>=77'
	$(PY) -m pip install -q -e '.[test]'
	touch $(STAMP)

# The compiled copy is built and its tests run beside mypy and the suite (its output in
# build/compiled-test.log, its last lines shown at the end): the build is 40 s of one core.
test: $(STAMP)
	$(PY) -m ruff check wiswarm_zenoh apps tests benchmarks examples
	@mkdir -p build
	@$(MAKE) --no-print-directory compiled-test >build/compiled-test.log 2>&1 & compiled=$$!; \
	echo "$(MAKE) compiled-test >build/compiled-test.log (in the background)"; \
	$(PY) -m mypy --strict wiswarm_zenoh apps examples && $(PY) -m pytest -n $(WORKERS); \
	status=$$?; wait $$compiled || { tail -n 40 build/compiled-test.log; status=1; }; \
	echo "the core compiled by mypyc (build/compiled-test.log):"; \
	tail -n 1 build/compiled-test.log; exit $$status

compiled-test: $(COMPILED_COPY)/.built
	cd $(COMPILED_COPY) && WISWARM_CORE_BUILD=compiled $(abspath $(PY)) -m pytest \
		-p no:cacheprovider tests/core $(filter tests/transport/test_%,$(POLL_PATH_TESTS))

$(COMPILED_COPY)/.built: $(STAMP) setup.py $(wildcard wiswarm_zenoh/core/*.py \
		wiswarm_zenoh/transport/*.py tests/core/*.py) $(POLL_PATH_TESTS)
	rm -rf $(COMPILED_COPY) && mkdir -p $(COMPILED_COPY)/tests/transport
	cp -r wiswarm_zenoh setup.py pyproject.toml README.md $(COMPILED_COPY)/
	cp -r tests/core tests/conftest.py $(COMPILED_COPY)/tests/
	cp $(POLL_PATH_TESTS) $(COMPILED_COPY)/tests/transport/
	rm -f $(addprefix $(COMPILED_COPY)/,$(CORE_SO))
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
