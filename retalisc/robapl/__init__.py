"""RobAPL (thesis chapter 7): BDI agents whose plans are PLEXIL-like node trees, with pause,
resume, pre-emption, wind-down nodes and shared resources (docs/robapl.md).

`syntax` reads agent files, `executor` runs the deliberation cycle, `conditions` answers node
conditions, `runner` reads event lines and writes traces, `plot` draws a run."""
