"""``skillbank experiment rail``: table, JSON, figure and errors."""

from __future__ import annotations

import json
import re

import pytest

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"




def test_paper_mode_json(cli, data_dir):
    code, out, _ = cli("experiment", "rail", "--data", data_dir / "rail", "--mode", "paper", "--json")
    assert code == 0
    doc = json.loads(out)
    assert doc["n_demos"] == 150
    assert isinstance(doc["elastic"]["n_clusters"], int) and isinstance(doc["elastic"]["ari"], float)
    assert doc["elastic"]["misclustered"] == 20
    assert doc["agglomerative"]["misclustered"] == 22
    assert doc["agglomerative"]["n_clusters"] == 3


def test_default_mode_table_and_plot(cli, data_dir, tmp_path):
    fig = tmp_path / "figs" / "rail.png"
    code, out, _ = cli("experiment", "rail", "--data", data_dir, "--plot", fig)
    assert code == 0
    assert "RAIL clustering, default mode: 150 demos (reaching 60, pushing 60, writing 30)" in out
    lines = out.splitlines()
    elastic = next(line for line in lines if line.startswith("elastic "))
    n_clusters, misclustered = int(elastic.split()[1]), int(elastic.split()[2])
    assert n_clusters == 3 and misclustered < 20
    assert "  cluster " in out and f"wrote {fig}" in out
    assert fig.read_bytes()[:8] == PNG_MAGIC
    # the composition table numbers clusters 0..k-1, as the JSON's composition rows are indexed
    header = lines.index(next(line for line in lines if line.startswith("elastic: "))) + 1
    ids = [int(line.split()[0]) for line in lines[header + 1:header + 1 + n_clusters]]
    assert ids == list(range(n_clusters))


def test_four_classes_json(cli, data_dir):
    code, out, _ = cli("experiment", "rail", "--data", data_dir / "rail", "--classes",
                       "reaching,pushing,pressing,writing", "--json")
    assert code == 0
    doc = json.loads(out)
    assert doc["n_demos"] == 209
    assert len(doc["elastic"]["composition"][0]) == 4


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        (["--classes", "reaching,flying"],
         r"^skillbank experiment rail: error: classes: expected names among"),
        (["--classes", "reaching"], r"classes: expected at least two different classes"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(cli, data_dir, extra, match):
    code, out, err = cli("experiment", "rail", "--data", data_dir / "rail", *extra)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1
    assert re.search(match, err)


def test_missing_data_folder(cli, tmp_path):
    code, _, err = cli("experiment", "rail", "--data", tmp_path / "nothing")
    assert code == 2
    assert "data_dir: expected a folder holding the RAIL dataset" in err


def test_usage_errors_exit_2(cli):
    with pytest.raises(SystemExit) as info:
        cli("experiment", "rail", "--mode", "paper")  # --data missing
    assert info.value.code == 2
    with pytest.raises(SystemExit) as info:
        cli("experiment", "rail", "--data", ".", "--mode", "quick")
    assert info.value.code == 2
