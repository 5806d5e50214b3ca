"""GRPO: group-relative policy optimisation without a critic (EmbodiChain's definition)."""
