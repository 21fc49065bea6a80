"""tools/spy_lines.py: py-spy's raw samples summed by innermost line, counted by hand."""


def test_shares_counted_by_hand(tool_script):
    tool = tool_script("spy_lines")
    raw = ["main (a.py:1);step (a.py:5);solve (q.py:9) 3\n",
           "main (a.py:1);step (a.py:6) 1\n",
           "import (b.py:2);solve (q.py:9) 2\n",
           "not a sample\n"]
    total, counts = tool.line_shares(raw, under="step")
    assert total == 4  # the import's 2 samples have no frame naming "step"
    assert counts == {"solve (q.py:9)": 3, "step (a.py:6)": 1}
    total, counts = tool.line_shares(raw)
    assert total == 6 and counts["solve (q.py:9)"] == 5


def test_bad_input_is_one_line_and_exit_code_2(tool_script, tmp_path, capsys):
    tool = tool_script("spy_lines")
    assert tool.main([str(tmp_path / "missing.txt")]) == 2
    empty = tmp_path / "empty.txt"
    empty.write_text("")
    assert tool.main([str(empty)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and all(line.startswith("spy_lines: error:") for line in err)
