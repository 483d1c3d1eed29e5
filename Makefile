# Stages of the pipeline. The virtual environment .venv is created on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
export OPENBLAS_NUM_THREADS ?= 1
export OMP_NUM_THREADS ?= 1

RINGDOWN ?= ../shared/data/chen2022-brb-hammer/HammerImpact.mat
MODE_HZ ?= 80.5

STUDY_DESIGNS ?= 100000
STUDY_CHUNK ?= 500
# The data defaults point into ../shared and a stage whose data is absent there is skipped with a message; a file or
# folder named on the command line (or in the environment) must exist: make stops before running anything.
$(foreach name,RINGDOWN ASB_DATA REFERENCE,$(if $(filter command line environment,$(origin $(name))),\
  $(if $(wildcard $($(name))),,$(error $(name)=$($(name)): no such file or folder))))
# dask.distributed scheduler address for the studies ("local": a LocalCluster here); empty: in this process.
SCHEDULER ?=
# Every stage logs its wall time and peak memory here; the report's provenance section reads it.
RUN_LOG ?= results/runs.jsonl
SURROGACY := $(BIN)/surrogacy --run-log $(RUN_LOG)
ASB_DATA ?= ../shared/data
REFERENCE ?= ../shared/reference

.PHONY: demo test test-slow beams fe fe-convergence calibrate rom freevib study study-beams study-asb study-full discrepancy discrepancy-modal-asb report bench clean system-packages

# The demo. The ASB study needs nothing of ours but the installed tool (its superelements are ABAQUS's), and fe and
# rom compute on one core: it runs beside them, its progress in $(ASB_LOG), and compiles the QSMA kernel into
# numba's cache for the beams' study as well. Ctrl-C stops both (exit 130 each); a failure of either stops the demo.
# (make -n runs a recipe line that calls $(MAKE), this one: DRY_RUN makes it print the ASB study, not start it.)
ASB_LOG := results/study-asb.log
DRY_RUN := $(findstring n,$(firstword -$(MAKEFLAGS)))
demo: $(STAMP)
	@mkdir -p results; asb=; \
	if [ -d "$(ASB_DATA)/asb-backbones" ]; then \
	  echo "study-asb: running beside beams, fe and rom; its progress: $(ASB_LOG)"; \
	  $(if $(DRY_RUN),echo "$(ASB_STUDY) > $(ASB_LOG) 2>&1 &",$(ASB_STUDY) > $(ASB_LOG) 2>&1) & asb=$$!; \
	else echo "study: $(ASB_DATA) not found, ASB study skipped (set ASB_DATA=folder)"; fi; \
	$(MAKE) --no-print-directory beams fe rom freevib || { status=$$?; [ -z "$$asb" ] || kill $$asb 2>/dev/null; wait; exit $$status; }; \
	[ -z "$$asb" ] || wait $$asb || { status=$$?; tail -n 5 $(ASB_LOG); echo "study-asb failed (exit $$status): $(ASB_LOG)"; exit $$status; }; \
	[ -z "$$asb" ] || echo "study-asb: $$(tail -n 1 $(ASB_LOG))"
	@$(MAKE) --no-print-directory study-beams discrepancy report

# The tests run one file per worker process (pytest-xdist; a file's fixtures are built once, by its worker), one
# worker per core of the CI machine: from a fresh clone the default run takes 10 min here instead of 17 in one
# process (the default-mesh superelements and numba's first compilation of the QSMA kernel are 8 of them).
TEST_WORKERS ?= 2
test: $(STAMP)
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile

# The long checks (pytest marker slow).
test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow -n $(TEST_WORKERS) --dist loadfile

beams: $(STAMP)
	$(SURROGACY) beams --out build/beams

# Stiffness, mass, bolt preload with frictionless contact, stress stiffness and tied modes of each beam.
fe: beams
	$(SURROGACY) fe --beams build/beams --out build/fe

# Mesh-convergence study of the tied first bending of the BRB (about 2 minutes).
fe-convergence: $(STAMP)
	$(SURROGACY) fe-convergence --beam BRB --out results/fe-convergence

# Joint springs of the BRB and the LBRB/SBRB geometry from the measured frequency ratios (about 3 minutes).
calibrate: $(STAMP)
	$(SURROGACY) calibrate --out results/calibration

# Whole-joint patches and the Hurty/Craig-Bampton superelement of each beam (60 virtual + 26 modal DOFs):
# build/rom/<beam>.npz, .mat, _first_bending.png and .json, cached per beam.
rom: fe
	$(SURROGACY) rom --beams build/beams --fe build/fe --out build/rom

# Amplitude-dependent frequency and damping of one mode from a measured ring-down (Hilbert / FreeVib).
freevib: $(STAMP)
	@if [ -f "$(RINGDOWN)" ]; then \
	  $(SURROGACY) freevib $(RINGDOWN) --mode-hz $(MODE_HZ) --per-channel --out results/freevib; \
	else echo "freevib: $(RINGDOWN) not found, skipped (set RINGDOWN=file)"; fi

# The surrogacy study (paper sections 4.4, 5.2) of the three beams on their virtual experiments, and of the real
# ASB assembly on its measured backbones where ../shared/data is present: results/study-<dataset>/report.md.
# STUDY_DESIGNS designs per friction model; a killed run resumes where it stopped, and chunks computed for
# other inputs (a rebuilt superelement, new measurements) are recomputed.
STUDY_OPTIONS = --reference $(REFERENCE) --restart-stale --set sample.n_designs=$(STUDY_DESIGNS) \
  --set sample.chunk_size=$(STUDY_CHUNK) $(if $(SCHEDULER),--scheduler $(SCHEDULER))
ASB_STUDY = $(SURROGACY) study --out results/study-asb --data $(ASB_DATA) --set study.dataset=asb $(STUDY_OPTIONS)
study: study-beams study-asb

study-beams: rom
	@if [ -f "$(REFERENCE)/paper_table1_low_amplitude.csv" ]; then \
	  $(SURROGACY) study --out results/study-beams --rom build/rom $(STUDY_OPTIONS); \
	else echo "study: $(REFERENCE) lacks the paper's Table 1, beams' study skipped (set REFERENCE=folder)"; fi

study-asb: $(STAMP)
	@if [ -d "$(ASB_DATA)/asb-backbones" ]; then $(ASB_STUDY); \
	else echo "study: $(ASB_DATA) not found, ASB study skipped (set ASB_DATA=folder)"; fi

# The paper's scale: 5,000,000 designs per friction model in chunks of 5,000 on a LocalCluster (or SCHEDULER=address),
# into the same results/study-* folders (the demo's smaller study there is replaced), then the report. Measured here
# (2 cores): the beams' exploration 41 min, about 1.2 GB for the scheduler and workers together.
study-full:
	$(MAKE) study report STUDY_DESIGNS=5000000 STUDY_CHUNK=5000 SCHEDULER=$(or $(SCHEDULER),local)

# The discrepancy loop: what the one-mode joint model lacks on the Chen 2022 ring-down (no FE model behind it:
# results/discrepancy/chen2022/), and what the studies' best fits on each structure's superelement miss (the three
# beams and the six ASB configurations: results/discrepancy/study-<structure>/), each with discrepancy.md (about
# 2 minutes).
discrepancy: $(STAMP)
	@if [ -f "$(RINGDOWN)" ]; then \
	  $(SURROGACY) discrepancy $(RINGDOWN) --mode-hz $(MODE_HZ) --out results/discrepancy/chen2022; \
	else echo "discrepancy: $(RINGDOWN) not found, skipped"; fi
	@for s in BRB LBRB SBRB; do \
	  if [ -f results/study-beams/analysis/fronts_jenkins.csv ]; then \
	    $(SURROGACY) discrepancy --study results/study-beams --structure $$s --out results/discrepancy/study-$$s; \
	  else echo "discrepancy: results/study-beams not analysed (make study), $$s skipped"; fi; done
	@for c in C1 C2 C3 C4 C4a CD1; do \
	  if [ -f results/study-asb/analysis/fronts_jenkins.csv ]; then \
	    $(SURROGACY) discrepancy --study results/study-asb --structure "ASB $$c" --out results/discrepancy/study-ASB_$$c; \
	  else echo "discrepancy: results/study-asb not analysed (make study), ASB $$c skipped"; fi; done

# The one-mode joint model on the six ASB backbones as well (about 3 minutes; not in make demo, whose ASB loop runs
# on each configuration's own superelement): results/discrepancy/ASB_<configuration>/.
discrepancy-modal-asb: $(STAMP)
	@for c in C1 C2 C3 C4 C4a CD1; do \
	  if [ -f "$(ASB_DATA)/asb-backbones/ASB_$${c}_20Nm_BB.mat" ]; then \
	    $(SURROGACY) discrepancy $(ASB_DATA)/asb-backbones/ASB_$${c}_20Nm_BB.mat --out results/discrepancy/ASB_$$c; \
	  else echo "discrepancy: $(ASB_DATA)/asb-backbones/ASB_$${c}_20Nm_BB.mat not found, skipped"; fi; done

# One Markdown file with every stage's figures and tables: results/report.md.
report: $(STAMP)
	$(SURROGACY) report --build build --results results --out results/report.md

bench: $(STAMP)
	$(BIN)/python -m benchmarks

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
