import os
import pickle

import yaml


def dump_yaml(filename: str, data, sort_keys: bool = False) -> None:
    os.makedirs(os.path.dirname(filename), exist_ok=True)
    data = data.to_dict() if hasattr(data, "to_dict") else data
    with open(filename, "w") as f:
        yaml.dump(data, f, default_flow_style=False, sort_keys=sort_keys)


def dump_pickle(filename: str, data) -> None:
    os.makedirs(os.path.dirname(filename), exist_ok=True)
    with open(filename, "wb") as f:
        pickle.dump(data, f)
