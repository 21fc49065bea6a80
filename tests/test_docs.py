"""The documentation: the site builds with ``mkdocs build --strict`` (every page in the nav exists,
every link and anchor resolves, every API identifier is found), the README stays short and
links into it, and the scenarios shown in the docs load as written."""

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def _yaml_blocks(path: Path) -> list[str]:
    return re.findall(r"```yaml\n(.*?)```", path.read_text(), flags=re.S)


def test_site_builds_strict(tmp_path):
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings_handlers.python")
    pytest.importorskip("material")
    out = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet", "--site-dir",
                          str(tmp_path / "site")], cwd=ROOT, capture_output=True, text=True, timeout=120,
                         env={**__import__("os").environ, "NO_MKDOCS_2_WARNING": "1"})
    assert out.returncode == 0, out.stdout + out.stderr
    assert (tmp_path / "site" / "api" / "index.html").exists()
    shutil.rmtree(tmp_path / "site")


def test_every_nav_page_exists_and_every_page_is_in_the_nav():
    config = (ROOT / "mkdocs.yml").read_text()
    nav = config[config.index("\nnav:"):]
    listed = set(re.findall(r":\s*([\w./-]+\.md)\s*$", nav, flags=re.M))
    assert listed, "mkdocs.yml has no nav"
    for page in listed:
        assert (DOCS / page).exists(), page
    pages = {p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md")}
    assert pages <= listed, f"pages not in the nav of mkdocs.yml: {sorted(pages - listed)}"


def test_readme_is_short_and_links_into_the_site():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 200
    links = re.findall(r"\]\((docs/[^)#]+\.md)", text)
    assert len(set(links)) >= 10
    for link in links:
        assert (ROOT / link).exists(), link
    assert "pip install -e '.[docs]' && mkdocs serve" in text
    picture = re.search(r"!\[[^]]*\]\((docs/img/[^)]+)\)", text)
    assert picture and (ROOT / picture[1]).exists()
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")


def test_every_public_name_is_in_the_api_reference():
    import nodnav

    text = (DOCS / "api.md").read_text()
    for name in nodnav.__all__:
        if name == "__version__":
            continue
        assert re.search(rf"(::: [\w.]+\.{name}\b|`nodnav\.{name}`)", text), name


def test_the_scenarios_shown_in_the_docs_load():
    from nodnav.api import build_scenario

    blocks = [b for path in (ROOT / "README.md", DOCS / "scenarios.md") for b in _yaml_blocks(path)]
    assert len(blocks) >= 3
    for block in blocks:
        scenario = build_scenario(yaml.safe_load(block))
        assert scenario.n_robots >= 2


def test_the_family_and_study_files_shown_in_the_docs_load():
    from nodnav.experiments.study import study_from_dict
    from nodnav.scenario.families import family_from_dict

    (family,) = _yaml_blocks(DOCS / "families.md")
    assert family_from_dict(yaml.safe_load(family)).name == "my-family"
    (study,) = _yaml_blocks(DOCS / "studies.md")
    spec = study_from_dict(yaml.safe_load(study))
    assert (spec.name, spec.scenarios, spec.trials) == ("mine", ("2r-case1", "3r-case4"), 10)
