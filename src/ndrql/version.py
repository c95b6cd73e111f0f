"""The package version and where the project lives (bottom layer: the checkpoints record the version, the
CLI prints it, and ``--help`` points to the documentation online, which a pip install does not carry)."""

__version__ = "0.1.0"

#: The project's repository.
PROJECT_URL = "https://github.com/ndrql/ndrql"
#: The documentation pages (``docs/*.md`` of the repository), as a browser opens them.
DOCS_URL = f"{PROJECT_URL}/blob/main/docs"
