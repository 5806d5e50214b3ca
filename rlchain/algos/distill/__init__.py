"""``algo: distill``: DAgger from a frozen PPO teacher into a student that sees less (docs/distillation.md)."""
