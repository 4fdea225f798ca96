//! Criterion benchmarks of trackfuse, in their own crate so that a test run does not
//! compile criterion. The benchmarks are in `benches/`: `cargo bench -p trackfuse-bench
//! --bench fusion_center` and `--bench pipeline`; BENCHMARKS.md gives their figures.
