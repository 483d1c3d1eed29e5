# The pipeline's stages, each a `surrogacy` subcommand. `make demo` runs them all (`surrogacy demo`: the ASB study
# beside beams, fe and rom, then the beams' study, the discrepancy loops and results/report.md); each step alone is
# `make <step>`. A measured-data step whose data is absent is skipped with one line saying why. The virtual
# environment .venv is created on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
export OPENBLAS_NUM_THREADS ?= 1
export OMP_NUM_THREADS ?= 1

# The public measured data: ../shared/data beside the repository where it is, else the project's data/, where
# `make data` downloads it. REFERENCE (empty: the paper's tables, pipeline/published.py) names a folder of your own.
DATA := $(if $(wildcard ../shared/data),../shared/data,data)
ASB_DATA ?= $(DATA)
REFERENCE ?=
RINGDOWN ?= $(DATA)/chen2022-brb-hammer/HammerImpact.mat
MODE_HZ ?= 80.5
STUDY_DESIGNS ?= 100000
STUDY_CHUNK ?= 500
# dask.distributed scheduler address for the studies ("local": a LocalCluster here); empty: in the study's process.
SCHEDULER ?=
# Every stage appends its wall time and peak memory here; the report's provenance section reads it.
RUN_LOG ?= results/runs.jsonl
# The tests run one file per worker process (pytest-xdist), one worker per core of the CI machine.
TEST_WORKERS ?= 2

# A data file or folder named on the command line (or in the environment) must exist: make stops before running.
$(foreach name,RINGDOWN ASB_DATA REFERENCE,$(if $(and $(filter command line environment,$(origin $(name))),$($(name))),\
  $(if $(wildcard $($(name))),,$(error $(name)=$($(name)): no such file or folder))))

SURROGACY := $(BIN)/surrogacy --run-log $(RUN_LOG)
DEMO := $(SURROGACY) demo --data $(ASB_DATA) $(if $(REFERENCE),--reference $(REFERENCE)) --ringdown $(RINGDOWN) \
  --mode-hz $(MODE_HZ) \
  --designs $(STUDY_DESIGNS) --chunk $(STUDY_CHUNK) $(if $(SCHEDULER),--scheduler $(SCHEDULER))
STEPS := study-asb beams fe rom freevib fit-asb study-beams discrepancy discrepancy-modal-asb fit-beams confidence-asb \
  confidence-beams report

.PHONY: demo test test-slow $(STEPS) study study-full fe-convergence tune-frequencies bench gpu-check-bundle epmc clean \
  system-packages data

demo: $(STAMP)
	$(DEMO)

test: $(STAMP)
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile

# The long checks (pytest marker slow).
test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow -n $(TEST_WORKERS) --dist loadfile

# One step of the demo each (not in the demo: discrepancy-modal-asb, the one-mode loop on the six ASB backbones;
# fit-beams, the beams' calibration; confidence-asb and confidence-beams, the surrogacy confidence at each dataset's
# bounds from the data); a stage's inputs are made first, and a stage whose output is current does nothing.
$(STEPS): $(STAMP)
	$(DEMO) --steps $@
fe: beams
rom: fe
study-beams: rom
fit-asb: study-asb
confidence-asb: fit-asb
fit-beams: study-beams
confidence-beams: fit-beams
discrepancy: freevib
study: study-asb study-beams

# The paper's scale: 5,000,000 designs per friction model in chunks of 5,000 on a LocalCluster (or SCHEDULER=address),
# into the same results/study-* folders, then the report.
study-full:
	$(MAKE) study report STUDY_DESIGNS=5000000 STUDY_CHUNK=5000 SCHEDULER=$(or $(SCHEDULER),local)

# Mesh-convergence study of the tied first bending of the BRB (about 2 minutes).
fe-convergence: $(STAMP)
	$(SURROGACY) fe-convergence --beam BRB --out results/fe-convergence

# Joint springs of the BRB and the LBRB/SBRB geometry tuned to the measured first-bending frequencies (about 3 minutes).
tune-frequencies: $(STAMP)
	$(SURROGACY) tune-frequencies --out results/frequency-tuning

bench: $(STAMP)
	ASB_DATA=$(ASB_DATA) $(BIN)/python -m benchmarks

# What the check of the CUDA path on a GPU machine reads (build/gpu-check, 35 MiB: the beams' superelements and
# study measurements, ASB CD1, the Python 3.12 wheels the machine lacks); its one command there is in
# benchmarks/gpu_check.py and docs/benchmarks.md.
gpu-check-bundle: rom study-beams
	ASB_DATA=$(ASB_DATA) $(BIN)/python -m benchmarks.gpu_check prepare build/gpu-check

# QSMA against the nonlinear mode by harmonic balance (EPMC) on the studies' representative designs, every friction
# model, the beams and the ASB's CD1 (results/epmc/study_<dataset>.csv, report section 10; 57 designs, 9 min of CPU,
# half an hour on a loaded 2-core machine; not part of the demo); a design already compared is kept.
epmc: $(STAMP)
	$(BIN)/python -m benchmarks.epmc_qsma --study results/study-beams --rom build/rom
	$(if $(wildcard results/study-asb/study.json),$(BIN)/python -m benchmarks.epmc_qsma --study results/study-asb \
	  --structures "ASB CD1" --data $(ASB_DATA))

# The public measured data (ASB backbones and reduced models, the Chen 2022 ring-down) into data/, hashes checked;
# SURROGACY_DATA_URL=URL takes them from a mirror.
data: $(STAMP)
	$(BIN)/surrogacy data fetch --out data

# Debian libraries that the gmsh wheel and off-screen PyVista load at import time.
system-packages:
	@bash scripts/system_packages.sh

$(STAMP): pyproject.toml
	@$(MAKE) --no-print-directory system-packages
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[test,cholmod]' || { \
	  echo "note: scikit-sparse (CHOLMOD) did not build; the FE solves fall back to SciPy's SuperLU"; \
	  $(BIN)/python -m pip install -q -e '.[test]'; }
	touch $(STAMP)

clean:
	rm -rf build results
