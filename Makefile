# Shortcuts for ./dev.sh (which needs nothing but bash on a fresh machine).
.PHONY: demo demo-spatial test test-slow bench setup lint
demo demo-spatial test test-slow bench:
	./dev.sh $@
setup:
	bash .ci/setup
lint:
	bash .ci/setup
	.venv/bin/ruff check cablefem tests demos benchmarks
