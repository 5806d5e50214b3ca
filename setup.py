"""Package metadata for rlchain: a PyTorch RL trainer that runs rl_games configs."""

from setuptools import find_packages, setup

EXTRAS = {
    "envpool": ["envpool>=0.8,<2"],
    "brax": ["brax>=0.12"],  # JAX on the CPU by default; tensors reach torch through DLPack
    # MuJoCo Playground (env_name: playground): MJX envs through the brax adapter's jitted batch
    "playground": ["playground>=0.2,<0.3"],
    "atari": ["ale-py>=0.9", "opencv-python-headless"],  # ale-py ships the ROMs; opencv: AtariPreprocessing
    "mujoco": ["gymnasium[mujoco]>=1.0,<2"],
    # onnxscript: torch's default (dynamo) ONNX exporter, which rl_games' ONNX notebooks call
    "onnx": ["onnx", "onnxruntime", "onnxscript"],
    "wandb": ["wandb"],
    "ray": ["ray[tune]>=2.9,<3"],  # [tune]: pandas, pyarrow for --tune with backend: ray
    "tune": ["optuna>=3"],
    # pygame-ce (the maintained pygame fork, same `pygame` module): gymnasium's classic-control rendering.
    # Not pygame itself: mpe2 (the pettingzoo extra) needs pygame-ce, and the two overwrite each other's files
    "video": ["moviepy>=1.0", "pygame-ce>=2.5"],
    # PettingZoo envs (env_name: pettingzoo); the MPE envs live in mpe2 since PettingZoo 1.25
    "pettingzoo": ["pettingzoo>=1.25,<2", "mpe2>=1.0,<2"],
    # the documentation site: mkdocs build --strict (mkdocs.yml; tests/unit/test_docs_site.py builds it)
    "docs": ["mkdocs>=1.6,<2", "mkdocs-material>=9.5,<10", "mkdocstrings[python]>=0.25,<2"],
    # nbclient, nbformat, ipykernel: tests/smoke/test_notebooks.py runs notebooks/ top to bottom;
    # the docs packages: tests/unit/test_docs_site.py builds the site
    # gym: OpenAI gym 0.26 (what Isaac Lab's rl-games extra installs), for the tests of its spaces;
    # stable-baselines3: the tests of rlchain.sb3 with SB3's own vec envs, callbacks and .zip files;
    # pytest-xdist: the unit and smoke tiers run on 2 workers (the README's test command), a file per worker
    "test": ["pytest>=7", "pytest-timeout", "pytest-xdist>=3", "ruff", "nbclient", "nbformat", "ipykernel",
             "gym==0.26.2",
             "stable-baselines3>=2.3,<3",
             "mkdocs>=1.6,<2", "mkdocs-material>=9.5,<10", "mkdocstrings[python]>=0.25,<2"],
    "bench": ["matplotlib"],  # benchmarks/curves.py plots (matplotlib is a core dependency now; kept for old commands)
    # mjlab (env_name: mjlab, vecenv_type: MJLAB): Isaac Lab's manager-based API on MuJoCo Warp. It pins
    # mujoco 3.11 (and rsl-rl-lib) where the mujoco / playground extras take mujoco 4: install it in its own
    # environment (constraints-mjlab.txt, the mjlab job of .ci/run); "all" leaves it out
    "mjlab": ["mjlab>=1.6,<2"],
}
SEPARATE = {"mjlab"}
EXTRAS["all"] = sorted({dep for name, deps in EXTRAS.items() if name not in SEPARATE for dep in deps})

setup(
    name="rlchain",
    version="0.1.0",
    description="PyTorch reinforcement learning with an rl_games-compatible config and runner",
    packages=find_packages(include=["rlchain", "rlchain.*"]),
    # the configs (rlchain train NAME), rl_games' example YAMLs the docs use and the shipped checkpoints
    # (--checkpoint NAME): rlchain.config.packaged finds them by name in an installed wheel
    package_data={"rlchain": ["configs/*.yaml", "configs/*/*.yaml", "configs/*/*.json", "checkpoints/*.pth"]},
    entry_points={"console_scripts": ["rlchain = rlchain.console:main"]},
    python_requires=">=3.11",  # constraints.txt pins packages that need 3.11 (numpy, contourpy, brax, ...)
    # torch is deliberately a range that an already installed torch satisfies: install the build you want
    # first (README: torch==2.13.0, the CPU one from https://download.pytorch.org/whl/cpu on Linux x86_64)
    # so pip does not replace it.
    # Upper bounds: the next major version of these is untested. The exact versions CI and the README's
    # test command install are in constraints.txt; .ci/run-latest checks the newest within these bounds.
    install_requires=[
        "torch>=2.1,<3",
        "gymnasium>=1.0,<2",
        "numpy>=1.24,<3",
        "pyyaml>=6",
        "tensorboard>=2.10",
        "matplotlib",  # rlchain compare draws its figures (as Stable-Baselines3 has it in its core dependencies)
    ],
    extras_require=EXTRAS,
    py_modules=[],
)
