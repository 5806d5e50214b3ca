import os


def retrieve_file_path(path: str, download_dir: str | None = None, force_download: bool = True) -> str:
    if not os.path.isfile(path):
        raise FileNotFoundError(f"Unable to find the file: {path}")
    return os.path.abspath(path)
