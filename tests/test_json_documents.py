"""The shared reader of the project's versioned JSON documents."""

from __future__ import annotations

import pytest

from stereo_obstacles.errors import CalibrationError, InputFileError
from stereo_obstacles.json_documents import check_document, load_json_file


def test_load_reports_missing_and_broken_files(tmp_path):
    with pytest.raises(InputFileError, match=r"^thing file .*none\.json does not exist$"):
        load_json_file(tmp_path / "none.json", what="thing")
    (tmp_path / "bad.json").write_text('{"a": ')
    with pytest.raises(CalibrationError, match="thing file .*bad.json is not valid JSON"):
        load_json_file(tmp_path / "bad.json", what="thing", error=CalibrationError)
    (tmp_path / "ok.json").write_text('{"a": [1, 2]}')
    assert load_json_file(tmp_path / "ok.json", what="thing") == {"a": [1, 2]}


@pytest.mark.parametrize("data, message", [
    ([1, 2], r"is not a x/y document \(format: 'list'\)"),
    ({"format": "other"}, r"is not a x/y document \(format: 'other'\)"),
    ({"format": "x/y", "version": 3}, r"unsupported x/y version 3 \(this is stereo-obstacles .*reads version 1\)"),
])
def test_check_refuses_other_formats_and_versions(data, message):
    with pytest.raises(InputFileError, match=message):
        check_document(data, format_name="x/y", version=1, source="f.json")


def test_check_returns_a_good_document():
    document = {"format": "x/y", "version": 1, "value": 5}
    assert check_document(document, format_name="x/y", version=1, source="f.json") is document


def test_is_document_of_recognises_only_its_own_format(tmp_path):
    from stereo_obstacles.json_documents import is_document_of

    cases = {"ours.json": '{"format": "stereo-obstacles/x", "version": 1}', "other.json": '{"format": "y"}',
             "list.json": "[1]", "torn.json": '{"format": "stereo-obs', "bytes.json": None}
    for name, text in cases.items():
        if text is None:
            (tmp_path / name).write_bytes(b"\xff\xfe")
        else:
            (tmp_path / name).write_text(text)
    assert [name for name in cases if is_document_of(tmp_path / name, "stereo-obstacles/x")] == ["ours.json"]
    assert not is_document_of(tmp_path / "missing.json", "stereo-obstacles/x")
    assert not is_document_of(tmp_path, "stereo-obstacles/x")                    # a folder
