def print_dict(val, nesting: int = -4, start: bool = True) -> None:
    print(val)
