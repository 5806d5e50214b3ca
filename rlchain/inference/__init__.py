"""Inference: the play loop, Player, multi-policy player, watch and video; export/ writes ONNX."""
