# Developer shortcuts; README gives the test command CI runs.
.PHONY: fuzz fuzz-long

# Every fuzz target for 60 s, two at a time (docs/robustness.md).
fuzz:
	python3 -m tests.fuzz all --runs 1000000 --seconds 60 --jobs 2

# The long run recorded in benchmarks/results/fuzz.json.
fuzz-long:
	python3 -m tests.fuzz all --runs 1000000 --seconds 200 --jobs 1 --json benchmarks/results/fuzz.json
