PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo demos test test-all bench docs gallery figures clean

$(STAMP): pyproject.toml
	test -d $(VENV) || $(PY) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e ".[test,mesh,docs]"
	touch $(STAMP)

## make demo: set everything up and run the default demo (writes out/pile.mp4)
demo: $(STAMP)
	$(BIN)/python demos/pile.py

## make demos: run every demo
demos: $(STAMP)
	for d in demos/[!_]*.py; do echo "== $$d"; $(BIN)/python $$d || exit 1; done

## make test: set everything up and run the fast test suite (what CI runs; slow tests deselected),
## then the Vulkan subset (tests/test_gpu.py; skipped, saying why, without a Vulkan device)
test: $(STAMP)
	$(BIN)/python -m pytest -q -m "not slow and not gpu" tests
	$(BIN)/python -m pytest -q -rxs -m "gpu and not slow" tests/test_gpu.py

## make test-all: every test, including the slow ones (full demos, README figures; ~1 h)
test-all: $(STAMP)
	$(BIN)/python -m pytest -q -m "not gpu" tests
	$(BIN)/python -m pytest -q -rxs -m gpu tests/test_gpu.py

## make bench: the performance benchmark (prints a table)
bench: $(STAMP)
	$(BIN)/python benchmarks/pile.py

## make docs: build the documentation site into docs/_build/html (warnings are errors)
docs: $(STAMP)
	rm -rf docs/api/generated          # autosummary stubs of modules that may have gone
	$(BIN)/python -m sphinx -b html -W --keep-going -q docs docs/_build/html
	@echo "docs: docs/_build/html/index.html"

## make gallery: a still and a short GIF of every demo, in docs/gallery (short runs)
gallery: $(STAMP)
	$(BIN)/python docs/make_gallery.py

## make figures: the verification figures of the documentation, in docs/accuracy
figures: $(STAMP)
	$(BIN)/python docs/make_figures.py

clean:
	rm -rf $(VENV) out .pytest_cache docs/_build
