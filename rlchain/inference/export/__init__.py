"""ONNX export of a trained policy (one or one per policy), with the inputs that check it."""
