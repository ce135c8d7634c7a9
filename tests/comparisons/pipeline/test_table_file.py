"""Trajectory files read bounded and by kind (``pipeline/table_file.py``): what is refused, and what reads the same."""

from __future__ import annotations

import bz2
import gzip
import lzma

import numpy as np
import pandas as pd
import pytest

import chatterbench.comparisons.pipeline.table_file as table_file
from chatterbench.comparisons.pipeline.table_file import TableFileError, read_table_file

TABLE = pd.DataFrame({"t": np.linspace(0.0, 1.0, 1001), "x1": 0.0, "x2": np.linspace(1.0, 0.5, 1001), "v1": 0.0,
                      "v2": -0.5, "note": "x"})


@pytest.mark.parametrize("suffix, compress", [(".csv", bytes), (".csv.gz", gzip.compress), (".csv.bz2", bz2.compress),
                                              (".csv.xz", lzma.compress)])
def test_a_csv_reads_the_same_whichever_compression(tmp_path, suffix, compress):
    path = tmp_path / f"run{suffix}"
    path.write_bytes(compress(TABLE.to_csv(index=False).encode()))
    read = read_table_file(path, ["t", "x1", "x2", "v1", "v2"])
    pd.testing.assert_frame_equal(read.frame, TABLE.drop(columns="note"))
    assert read.frame.attrs["columns"] == list(TABLE.columns) and read.row(0) == "row 1 (line 2)"


def test_a_parquet_file_reads_only_the_columns_asked_and_names_the_others(tmp_path):
    TABLE.to_parquet(tmp_path / "run.parquet")
    read = read_table_file(tmp_path / "run.parquet", ["t", "x2"])
    assert list(read.frame.columns) == ["t", "x2"] and read.frame.attrs["columns"] == list(TABLE.columns)
    assert read.row(4) == "row 5"


def test_a_gzip_bomb_stops_at_the_limit_whatever_its_trailer_says(tmp_path, monkeypatch):
    # 8 MiB of rows against a 4 MiB limit, in two members: the last member's trailer says 4 MiB, not over it
    monkeypatch.setattr(table_file, "MAX_TABLE_BYTES", 4 * 2**20)
    member = gzip.compress(b"0.001,0,0.5,0,0\n" * (2**18), 9)
    path = tmp_path / "bomb.csv.gz"
    path.write_bytes(gzip.compress(b"t,x1,x2,v1,v2\n") + member + member)
    with pytest.raises(TableFileError, match="decompressed, larger than 4 MiB"):
        read_table_file(path)
    half = gzip.compress(b"0.001,0,0.5,0,0\n" * (2**17), 9)
    path.write_bytes(gzip.compress(b"t,x1,x2,v1,v2\n") + half)  # the other way: 2 MiB, read
    assert len(read_table_file(path).frame) == 2**17


def test_a_parquet_file_is_bounded_by_its_footer(tmp_path, monkeypatch):
    TABLE.to_parquet(tmp_path / "run.parquet")
    monkeypatch.setattr(table_file, "MAX_TABLE_BYTES", 1000)
    with pytest.raises(TableFileError, match=r"1001 rows, 0 MiB uncompressed: larger than"):
        read_table_file(tmp_path / "run.parquet")


@pytest.mark.parametrize("content, words", [
    (b"t,x1,x2,v1,v2\n" + b"a" * (2**20 + 10), "line near line 2 is longer than 1 MiB"),  # no newline at its end
    (b"t,x1,x2,v1,v2\n0,\xe9,1,0,0\n", "not UTF-8 text"),
    (b"t,x1\n0,1\n\x00\x00", "NUL byte at byte 9"),
])
def test_what_is_not_a_csv_text_is_refused_where_it_is_found(tmp_path, content, words):
    path = tmp_path / "bad.csv"
    path.write_bytes(content)
    with pytest.raises(TableFileError, match=words):
        read_table_file(path)


def test_only_empty_cells_and_nan_are_missing_values(tmp_path):
    path = tmp_path / "run.csv"
    path.write_text("t,x1\n0,1\n1,\n2,nan\n3,NA\n4,n/a\n")
    assert read_table_file(path).frame["x1"].tolist()[3:] == ["NA", "n/a"]
