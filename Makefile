# The project's commands. `make test` and `make demo` work on a fresh machine:
# they install what they need (Rust toolchain components, a Python venv).
SHELL := /bin/bash
.DEFAULT_GOAL := help

CARGO ?= cargo

.PHONY: help test demo bench lint rust-setup rust-lint rust-test

help:
	@echo "make demo   - simulate the paper's Fig. 4 run and compare MTE with PI-SR"
	@echo "make test   - formatting, clippy and every test"
	@echo "make bench  - criterion benchmarks"
	@echo "make lint   - formatting and clippy only"

rust-setup:
	@command -v rustup >/dev/null 2>&1 && rustup component add rustfmt clippy >/dev/null 2>&1 || true

rust-lint: rust-setup
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings

rust-test: rust-setup
	$(CARGO) test --workspace

lint: rust-lint

test: rust-lint rust-test

demo: rust-setup
	$(CARGO) run --release -p bearing-slam --example fig4_demo

bench: rust-setup
	$(CARGO) bench -p bearing-slam
