"""One feature measured against its alternative: APPO vs PPO, distillation vs scratch, PBT, evaluation scripts."""
