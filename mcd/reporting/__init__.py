"""The parts of `python -m mcd.report` (docs/benchmark.md "Reports"), one module per table or figure:
`runs` (finding and reading run dirs), `tables` (Table 1, components, transfer), `spp`, `speed`, `strips`,
`frames` (per-frame PSNR), `provenance`, `paper` (the paper's numbers), `select` (choosing runs, markdown),
`outputs` (what each writer declares it writes in a report's folder)."""
