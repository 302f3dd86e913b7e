#!/usr/bin/env bash
# Re-render the sample images in assets/images/ from their specifications (the list in
# tests/suite/vision.rs, rendered by fleetmap::vision::synth, deterministic) and rewrite the golden
# results assets/images/golden.json. Review the diff before committing.
set -euo pipefail
cd "$(dirname "$0")/.."
REGENERATE=1 cargo test --test suite vision::golden_sample_images -- --exact
