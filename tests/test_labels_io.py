"""Real shop label files (issue 24): graded and coded labels, several raters, a batch column, extra
columns kept and ignored; the errors still name the file, the line and the column."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.io.points import parse_points, read_points, write_points
from millstab.points import PointSet, grade_of_cell, label_of_grade, parse_label_codes


def parse(text, labels=None):
    return parse_points(text, "cuts.csv", labels)


def test_words_synonyms_and_probabilities():
    ps = parse("rpm,depth_mm,label\n5000,1,Stable\n5000,2,uncertain\n5000,3,CHATTER\n5100,1,0.2\n5100,2,0.5\n"
               "5100,3,0.9\n5200,1,70 %\n5200,2,\n5300,1,unsure\n")
    np.testing.assert_array_equal(ps.grade[:7], [0, 0.5, 1, 0.2, 0.5, 0.9, 0.7])
    assert np.isnan(ps.grade[7]) and ps.grade[8] == 0.5
    assert list(ps.label) == ["stable", "marginal", "chatter", "stable", "marginal", "chatter", "chatter", "",
                              "marginal"]
    assert ps.boundary.tolist() == [False] * 7 + [True, False]
    assert ps.raters == ("label",) and ps.ratings.shape == (9, 1)


def test_nearest_class_edges():
    # < 1/3 stable, > 2/3 chatter, else marginal; NaN: boundary point
    g = np.array([0.0, 0.333, 1 / 3, 0.5, 2 / 3, 0.667, 1.0, np.nan])
    assert list(label_of_grade(g)) == ["stable", "stable", "marginal", "marginal", "marginal", "chatter", "chatter", ""]


def test_codes_need_the_mapping_and_the_error_suggests_it():
    text = "rpm,depth_mm,label\n5000,1,0\n5000,2,1\n5000,3,2\n"
    with pytest.raises(InputError) as e:
        parse(text)
    assert e.value.field == "cuts.csv line 4, label" and "--labels 0=stable,1=marginal,2=chatter" in str(e.value)
    ps = parse(text, "0=stable,1=marginal,2=chatter")
    assert list(ps.label) == ["stable", "marginal", "chatter"] and ps.grade.tolist() == [0, 0.5, 1]
    # "2.0" is the same code as "2"; a code map may give probabilities too
    assert parse("rpm,depth_mm,label\n5000,1,2.0\n", {"2": 1.0}).label[0] == "chatter"
    assert parse_label_codes("a=0.25, B=unsure") == {"a": 0.25, "b": 0.5}
    with pytest.raises(InputError) as e:
        parse("rpm,depth_mm,label\n5000,1,3\n", "0=stable,1=marginal,2=chatter")
    assert "codes of --labels" in str(e.value) and e.value.field == "cuts.csv line 2, label"


@pytest.mark.parametrize("text", ["0=stable,1", "=stable", "0=wobbly", "0=1.5", "0=stable,0=chatter"])
def test_bad_code_maps(text):
    with pytest.raises(InputError, match="--labels"):
        parse_label_codes(text)


def test_yes_no_is_ambiguous_unless_mapped():
    with pytest.raises(ValueError, match="yes=chatter,no=stable"):
        grade_of_cell("yes")
    assert grade_of_cell("YES", parse_label_codes("yes=chatter,no=stable")) == 1.0
    with pytest.raises(ValueError, match="stable"):
        grade_of_cell("chatty")


def test_two_raters_mean_grade_and_ratings_kept():
    ps = parse("rpm,depth_mm,label_op1,label_op2\n5000,1,stable,stable\n5000,2,stable,chatter\n"
               "5000,3,chatter,\n5000,4,,\n5000,2.5,marginal,chatter\n")
    assert ps.raters == ("op1", "op2")
    np.testing.assert_array_equal(ps.ratings[:3], [[0, 0], [0, 1], [1, np.nan]])
    assert np.isnan(ps.ratings[3]).all()
    np.testing.assert_array_equal(ps.grade[[0, 1, 2, 4]], [0, 0.5, 1, 0.75])
    assert list(ps.label) == ["stable", "marginal", "chatter", "", "chatter"]
    sub = ps.subset(np.array([False, True, False, False, True]))
    np.testing.assert_array_equal(sub.ratings, [[0, 1], [0.5, 1]])
    assert sub.raters == ("op1", "op2")
    # rater_NAME and labelN name raters too
    assert parse("rpm,depth_mm,rater_ann,label2\n5000,1,stable,chatter\n").raters == ("ann", "2")


def test_operator_columns_under_other_names_are_named_not_read_as_boundary_points():
    """A shop's file with its operators' columns named op1, op2 (not label_NAME) has no label column: every row
    would be a boundary point (a measured limit), which the update then fits as such (it did, silently but for
    "ignored columns"). With --labels that is an error naming the columns to rename; without, a warning; a
    constant feed column or a notes column is not mistaken for labels."""
    text = ("rpm,depth_mm,op1,op2,feed,notes\n5000,1,0,0,0.1,ok\n5000,2,2,1,0.1,\n5100,1,0,0,0.1,loud\n")
    with pytest.raises(InputError, match="no label column .*the columns op1, op2 hold labels: name them label_op1, "
                                         "label_op2"):
        parse(text, "0=stable,1=marginal,2=chatter")
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        ps = parse(text)
    msgs = [str(x.message) for x in w]
    assert msgs[0].startswith("cuts.csv: no label column, so every row is read as a boundary point")
    assert "op1, op2 hold labels" in msgs[0] and "feed" not in msgs[0] and "notes" not in msgs[0]
    assert list(ps.label) == ["", "", ""]
    fixed = parse(text.replace("op1,op2", "label_op1,label_op2", 1), "0=stable,1=marginal,2=chatter")
    assert fixed.raters == ("op1", "op2") and list(fixed.label) == ["stable", "chatter", "stable"]
    with warnings.catch_warnings(record=True) as w:  # a points file of boundary points: no label note
        warnings.simplefilter("always")
        parse("rpm,depth_mm,notes\n5000,1,a\n5100,2,b\n")
    assert [str(x.message) for x in w] == ["cuts.csv: ignored columns: notes (kept, not used)"]


def test_label_words_under_another_column_name_are_refused_not_read_as_boundary_points():
    """A column 'result' holding stable/chatter words (no label column): every row read as a measured limit made an
    update blame the hammer test for the contradiction (seen in a user test); such a file is refused, naming the
    column to rename. Codes alone (0/1/2) stay a warning: a column of small integers may be something else."""
    with pytest.raises(InputError, match="no label column, so every row would be read as a boundary point.*the "
                                         "column result holds labels: name it label"):
        parse("rpm,depth_mm,result\n12150,4.41,stable\n4850,1.91,chatter\n")
    with pytest.raises(InputError, match="op1, op2 hold labels"):
        parse("rpm,depth_mm,op1,op2\n12150,4.41,stable,stable\n4850,1.91,chatter,chatter\n12700,3.64,stable,\n")


def test_a_code_left_out_of_the_labels_mapping_is_an_error_not_a_probability():
    """--labels 0=stable,2=chatter on a file that also writes 1 (marginal): the 1 was read as P(chatter) = 1, a
    chatter cut, silently. With numeric codes mapped, a number that is none of them is refused, naming the line,
    the column and the codes; a mapping of words still lets probabilities through."""
    text = "rpm,depth_mm,label\n12150,4.41,0\n4850,1.91,2\n9850,3.03,1\n"
    with pytest.raises(InputError, match=r"line 4, label.*'1' is not one of the codes of --labels \(0, 2\)"):
        parse(text, "0=stable,2=chatter")
    assert list(parse(text, "0=stable,1=marginal,2=chatter").label) == ["stable", "chatter", "marginal"]
    words = parse("rpm,depth_mm,label\n5000,1,ok\n5100,1,0.8\n", "ok=stable,nok=chatter")
    np.testing.assert_allclose(words.grade, [0.0, 0.8])


def test_blank_label_cells_among_labelled_cuts_are_named():
    """A blank label cell in a file of labelled cuts is read as a boundary point (the documented format), which a
    forgotten label also produces: the reader names those lines; a file of boundary points alone says nothing."""
    text = "rpm,depth_mm,label\n12150,4.41,stable\n4850,1.91,\n12700,3.64,chatter\n5000,1.5,\n"
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        ps = parse(text)
    assert list(ps.label) == ["stable", "", "chatter", ""]
    assert [str(x.message) for x in w] == [
        "cuts.csv: 2 rows without a label (lines 3, 5) are read as boundary points (measured limits), the others "
        "as test cuts; write stable, marginal or chatter there if they are test cuts"]
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        parse("rpm,depth_mm,label\n12150,4.41,\n4850,1.91,\n")
    assert not w


@pytest.mark.parametrize("word,example", [("OK", "ok=stable,nok=chatter"), ("NOK", "nok=chatter,ok=stable"),
                                          ("light chatter", "light chatter=marginal,ok=stable")])
def test_a_shops_own_label_words_are_refused_with_a_mapping_to_copy(word, example):
    """OK / NOK and the like are a shop's vocabulary: refused (never guessed), naming the line and column, with a
    --labels example shaped like the word; the example, given, reads the file."""
    text = f"rpm,depth_mm,label\n5000,1,stable\n6000,2,{word}\n"
    with pytest.raises(InputError, match=f"cuts.csv line 3, label.*--labels {example}"):
        parse(text)
    assert parse(text, example).label[1] == {"ok": "stable", "nok": "chatter"}.get(word.lower(), "marginal")


@pytest.mark.parametrize("cell", ["OK", "2", "yes"])
def test_identify_which_has_no_labels_option_is_not_told_to_use_it(cell, tmp_path, capsys):
    """`millstab identify` reads points without --labels: an unknown label used to be answered "map your own
    words with --labels", an option identify refuses. Now the message says what the file may hold."""
    from millstab.cli import main

    pts = tmp_path / "pts.csv"
    pts.write_text(f"rpm,depth_mm,label\n5000,1,\n6000,1.2,{cell}\n7000,1.1,\n")
    assert main(["identify", "example:ex3", str(pts), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "pts.csv line 3, label" in err and "'stable', 'chatter', 'marginal'" in err
    assert "no --labels option" in err and "--labels " not in err.replace("no --labels option", "")
    with pytest.raises(InputError, match="no --labels option"):
        read_points(pts, labels_option=False)
    with pytest.raises(InputError, match="with --labels|codes of --labels|map it with --labels"):
        read_points(pts)  # the commands that have --labels still suggest it


def test_extra_columns_kept_with_one_note_and_batch_parsed():
    text = ("rpm,depth_mm,label,feed,notes,date\n5000,1,stable,0.1,good finish,2024-05-01\n"
            "5000,2,chatter,0.1,,2024-05-02\n")
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        ps = parse(text)
    msgs = [str(x.message) for x in w]
    assert msgs == ["cuts.csv: ignored columns: feed, notes (kept, not used)"]
    assert ps.batch.tolist() == ["2024-05-01", "2024-05-02"]
    assert ps.extra["notes"].tolist() == ["good finish", ""] and ps.extra["feed"].tolist() == ["0.1", "0.1"]
    assert ps.subset(np.array([1])).extra["notes"].tolist() == [""]
    # batch wins over date; date is then an extra column
    with pytest.warns(UserWarning, match="ignored columns: date"):
        ps = parse("rpm,depth_mm,label,batch,date\n5000,1,stable,A,2024\n")
    assert ps.batch.tolist() == ["A"] and ps.extra == {"date": np.array(["2024"])}


@pytest.mark.parametrize("text,field,words", [
    ("rpm,depht_mm,label\n5000,1,stable\n", "cuts.csv header",
     "unknown column 'depht_mm' looks like a misspelt 'depth_mm'"),
    ("rpm,depth_mm,lable\n5000,1,stable\n", "cuts.csv header", "misspelt 'label'"),
    ("rpm,depth_mm,labels\n5000,1,stable\n", "cuts.csv header", "misspelt 'label'"),
    ("rpm,depth_mm,label,weigth\n5000,1,stable,2\n", "cuts.csv header", "misspelt 'weight'"),
    ("rpm,depth_mm,label_a,label_b\n5000,1,stable,chatty\n", "cuts.csv line 2, label_b", "stable"),
    ("rpm,depth_mm,label,chatter_hz\n5000,1,0.2,900\n", "cuts.csv line 2, chatter_hz", "stable"),
    ("rpm,depth_mm,label\n5000,1,1.5\n", "cuts.csv line 2, label", "--labels"),
    ("rpm,depth_mm,label\n5000,1,-0.1\n", "cuts.csv line 2, label", "--labels"),
])
def test_errors_still_name_file_line_and_column(text, field, words):
    with pytest.raises(InputError) as e:
        parse(text)
    assert e.value.field == field and words in str(e.value)


@pytest.mark.parametrize("header,bad,meant", [
    ("label_op1,lable_op2", "lable_op2", "label_op2"), ("lable_op1,label_op2", "lable_op1", "label_op1"),
    ("label_op1,labl_op2", "labl_op2", "label_op2"), ("labels_1,labels_2", "labels_1", "label_1"),
    ("rater_a,rate_b", "rate_b", "rater_b")])
def test_a_misspelt_rater_column_is_an_error_not_a_dropped_operator(header, bad, meant):
    """A second operator's column misspelt (lable_op2) was an ignored column with a warning: that operator's labels
    were dropped; with a chatter_hz column the error blamed a frequency on a 'boundary point' instead."""
    for tail, row in (("", ""), (",chatter_hz", ",900")):
        text = f"rpm,depth_mm,{header}{tail}\n5000,1,stable,chatter{row}\n5000,2,chatter,{row}\n"
        with pytest.raises(InputError) as e:
            parse(text)
        assert e.value.field == "cuts.csv header" and e.value.value == bad
        assert f"looks like a misspelt rater column {meant!r} and holds labels" in str(e.value)


def test_a_column_only_named_like_a_rater_is_kept():
    """The likeness alone is no error: a column whose cells are not labels stays an ignored column."""
    with pytest.warns(UserWarning, match="ignored columns: rate_1"):
        ps = parse("rpm,depth_mm,label,rate_1\n5000,1,stable,0.37\n5000,2,chatter,0.52\n")
    assert ps.raters == ("label",) and ps.extra["rate_1"].tolist() == ["0.37", "0.52"]


def test_round_trip_of_grades_raters_batch_and_extras(tmp_path):
    with pytest.warns(UserWarning, match="notes"):
        ps = parse("rpm,depth_mm,label_op1,label_op2,batch,notes\n5000,1,stable,0.25,d1,x\n5000,2,0.6,chatter,d2,\n"
                   "5100,1.5,,,d2,boundary\n")
    with pytest.warns(UserWarning, match="notes"):
        back = read_points(write_points(tmp_path / "a.csv", ps))
    np.testing.assert_array_equal(back.ratings, ps.ratings)
    np.testing.assert_array_equal(back.grade, ps.grade)
    assert back.raters == ps.raters and back.label.tolist() == ps.label.tolist()
    assert back.batch.tolist() == ["d1", "d2", "d2"] and back.extra["notes"].tolist() == ["x", "", "boundary"]
    one = PointSet([5000, 5000], [1, 2], ["marginal", "chatter"], grade=[0.45, 1.0])
    back = read_points(write_points(tmp_path / "b.csv", one))
    np.testing.assert_array_equal(back.grade, [0.45, 1.0])
    assert back.label.tolist() == ["marginal", "chatter"]


def test_old_files_read_as_before(tmp_path):
    ps = parse("rpm,depth_mm,label,weight,chatter_hz\n5500,1.2,,,\n5600,1.5,chatter,2,1012\n5600,1,stable,,\n")
    assert ps.label.tolist() == ["", "chatter", "stable"] and ps.weight.tolist() == [1, 2, 1]
    assert ps.raters == ("label",) and ps.extra == {} and (ps.batch == "").all()
    assert np.isnan(ps.grade[0]) and ps.grade[1:].tolist() == [1, 0]


@pytest.mark.parametrize("depths,words", [(("0.001", "0.002"), "metres? 0.002 m is 2 mm"),
                                          (("1000", "2000"), "micrometres? 2000 µm is 2 mm")])
def test_depths_on_another_scale_are_read_as_written_and_warned(depths, words):
    """A file of depths in metres or micrometres is read as written (mm), with one warning naming the likely unit;
    ordinary depths (0.05-60 mm here) raise no warning."""
    text = f"rpm,depth_mm,label\n5000,{depths[0]},stable\n6000,{depths[1]},chatter\n"
    with pytest.warns(UserWarning, match=f"deepest cut is {depths[1]} mm .*" + re.escape(words)):
        ps = parse(text)
    assert ps.depth_mm.tolist() == [float(d) for d in depths]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parse("rpm,depth_mm,label\n5000,0.05,stable\n6000,60,chatter\n")


def test_dates_in_two_formats_are_warned_as_two_days():
    """A date column whose later rows were written 04/03/2026 instead of 2026-03-04 read, silently, as a fourth test
    day (one day split in two in validate's leave-one-day-out folds and under a batch effect); now one warning names
    the column, each format's first cell and its line. One format in two digit counts (4.3.26, 04.03.26) and
    session names (A, B) raise none."""
    text = ("rpm,depth_mm,label,date\n5000,1,stable,2026-03-02\n5000,2,chatter,2026-03-04\n"
            "5100,1.5,stable,04/03/2026\n")
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        ps = parse(text)
    assert [str(x.message) for x in w] == [
        "cuts.csv: the column date writes its dates in 2 formats (2026-03-02 on line 2; 04/03/2026 on line 4): each "
        "distinct text is its own test day, so a day written two ways counts as two (in validate's leave-one-day-out "
        "folds and a batch effect); write every date in one format"]
    assert ps.batch.tolist() == ["2026-03-02", "2026-03-04", "04/03/2026"]  # read as written
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parse("rpm,depth_mm,label,day\n5000,1,stable,4.3.26\n5000,2,chatter,04.03.26\n")
        parse("rpm,depth_mm,label,session\n5000,1,stable,A\n5000,2,chatter,B\n")


@pytest.mark.parametrize("cell,codes", [("?", None), ("?", "0=stable,2=chatter"), ("n/a", None)])
def test_a_question_mark_is_answered_with_its_two_readings(cell, codes):
    """An operator's '?' suggested '--labels ?=stable,nok=chatter' (a doubt mapped to a verdict), or with codes
    only listed them; now the message names the file, line, column and value and says how to write 'cannot tell'."""
    with pytest.raises(InputError) as e:
        parse(f"rpm,depth_mm,label_op1,label_op2\n5000,1,stable,{cell}\n5000,2,chatter,chatter\n", codes)
    assert e.value.field == "cuts.csv line 2, label_op2" and e.value.value == cell
    assert str(e.value).endswith(f"{cell!r} reads as 'cannot tell': write marginal there (near the limit), leave the "
                                 f"cell empty (no label from this rater), or map it, e.g. --labels {cell}=marginal")
    assert parse(f"rpm,depth_mm,label\n5000,1,{cell}\n5000,2,chatter\n", f"{cell}=marginal").grade.tolist() == [.5, 1]
