"""Reading a file of an input folder (``report --tune DIR``) without following a link out of it (issue 45)."""

from __future__ import annotations

import os

import pytest

from chatterbench.reference.errors import InputError
from chatterbench.reference.tables import read_text


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "outside.txt").write_text("outside")
    (tmp_path / "d" / "engine").mkdir(parents=True)
    (tmp_path / "d" / "engine" / "a.json").write_text("inside")
    return tmp_path


def test_a_file_of_the_folder_is_read(folder):
    assert read_text(folder / "d" / "engine" / "a.json", "a.json", folder=folder / "d") == "inside"


def test_the_folder_itself_may_be_a_link(folder):
    (folder / "alias").symlink_to("d")  # the user's to name, as --out's
    assert read_text(folder / "alias" / "engine" / "a.json", "a.json", folder=folder / "alias") == "inside"


@pytest.mark.parametrize("planted, path, named", [
    ("d/b.json", "d/b.json", "what: a symbolic link (-> ../outside.txt)"),  # the file
    ("d/linked", "d/linked/a.json", "linked is a symbolic link (-> engine)"),  # a folder on the way, even inside
])
def test_a_link_in_the_folder_is_refused_by_name(folder, planted, path, named):
    (folder / planted).symlink_to("../outside.txt" if planted.endswith(".json") else "engine")
    with pytest.raises(InputError, match=named.replace("(", r"\(").replace(")", r"\)")):
        read_text(folder / path, "what", folder=folder / "d")


def test_a_path_out_of_the_folder_is_refused(folder):
    with pytest.raises(InputError, match="not inside"):
        read_text(folder / "d" / ".." / "outside.txt", "what", folder=folder / "d")
    assert os.path.exists(folder / "outside.txt")
