"""Envs on Ray: env runners on Ray workers and the cluster connection."""
