"""Env wrappers and adapters: spaces and dtypes, action repeat, Dict obs, shaping, masks, success, info means."""
