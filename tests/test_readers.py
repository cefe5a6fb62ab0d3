"""Readers (the gml, svg and text plugins over :mod:`inkmotion.inputs`) and ``read_input``
dispatch, on small made inputs."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from inkmotion.errors import InputError
from inkmotion.inputs import gml, hershey, svg
from inkmotion.inputs.gml import read_gml, up_rotation
from inkmotion.inputs.hershey import render_text
from inkmotion.inputs.svg import flatten_segment, read_svg
from inkmotion.kinds.read import read_input
from inkmotion.plugins.gml import GmlReader
from inkmotion.plugins.hershey import HersheyTextReader
from inkmotion.plugins.svg import SvgReader

DATA = Path(__file__).resolve().parent / "data"
SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def data(name: str) -> str:
    return str(DATA / name)


def shared_gml(name: str) -> str:
    path = SHARED / "gml" / name
    if not path.is_file():
        pytest.skip(f"shared sample data {path} is not present")
    return str(path)


def bbox(traces) -> tuple[np.ndarray, np.ndarray]:
    pts = np.vstack([s[:, :2] for s in traces.strokes])
    return pts.min(axis=0), pts.max(axis=0)


# --- GML XML -----------------------------------------------------------------------------


def test_gml_xml_screen_bounds_and_pen_up_skipped():
    t = read_gml(data("tag.gml"))
    assert len(t.strokes) == 2  # the isdrawing="false" stroke is skipped
    assert [len(s) for s in t.strokes] == [3, 2]
    np.testing.assert_allclose(t.strokes[0], [[0, 0], [200, 0], [200, 100]])  # x*200, y*100
    np.testing.assert_allclose(t.strokes[1], [[100, 50], [100, 75]])
    lo, hi = bbox(t)
    assert (hi - lo)[0] / (hi - lo)[1] == pytest.approx(2.0)
    assert t.source == data("tag.gml")


def test_gml_times_kept_in_meta():
    t = read_gml(data("tag.gml"))
    np.testing.assert_allclose(t.meta["t"][0], [0.2, 0.3, 0.4])
    np.testing.assert_allclose(t.meta["t"][1], [0.5, 0.6])  # the older <time> element


def test_gml_up_vector_rotates_drawing_upright():
    t = read_gml(data("rotated_up.gml"))
    # up = (1, 0): (x, y) -> (y, -x) after scaling by screenBounds (200, 100)
    np.testing.assert_allclose(t.strokes[0], [[0, 0], [0, -200], [100, -200]], atol=1e-12)


@pytest.mark.parametrize(
    ("up", "expected"),
    [
        ((0.0, -1.0), [[1, 0], [0, 1]]),
        ((1.0, 0.0), [[0, 1], [-1, 0]]),
        ((-1.0, 0.0), [[0, -1], [1, 0]]),
        ((0.0, 1.0), [[-1, 0], [0, -1]]),
    ],
)
def test_up_rotation_maps_up_to_minus_y(up, expected):
    r = up_rotation(up)
    np.testing.assert_allclose(r, expected, atol=1e-12)
    np.testing.assert_allclose(r @ np.array(up), [0.0, -1.0], atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)  # a rotation, never a mirror


def test_gml_several_tags_and_drawings():
    t = read_gml(data("two_tags.gml"))  # upper-case <GML>, no header
    assert len(t.strokes) == 3
    assert t.meta["tags"] == 2


# --- GML JSON / JSONP --------------------------------------------------------------------


@pytest.mark.parametrize("name", ["tag.json", "tag.jsonp"])
def test_gml_json_forms(name):
    t = read_gml(data(name))
    # stroke 2 is isDrawing=false, stroke 3 a single point (a tap: a dab, second)
    assert [len(s) for s in t.strokes] == [3, 2, 2]
    np.testing.assert_allclose(t.strokes[0], [[0, 0], [640, 0], [640, 480]])
    np.testing.assert_allclose(t.strokes[1][0], [320, 240])  # the tap, in its place
    np.testing.assert_allclose(t.strokes[2], [[160, 240], [480, 240]])
    assert "t" not in t.meta  # the last stroke has no times


@pytest.mark.parametrize(
    ("name", "strokes", "points"), [("49867.json", 7, 723), ("49873.json", 5, 614)]
)
def test_gml_000000book_samples(name, strokes, points):
    t = read_input(shared_gml(name))
    assert (len(t.strokes), t.n_points) == (strokes, points)
    lo, hi = bbox(t)
    assert np.all(lo >= 0) and hi[0] <= 640 and hi[1] <= 480
    assert len(t.meta["t"]) == strokes


def test_gml_shared_xml_sample():
    t = read_input(shared_gml("temptTag-2010_6_7_14_52_1.gml"))
    assert len(t.strokes) >= 1


@pytest.mark.parametrize("name", ["minimal.gml", "spec_example.gml"])
def test_gml_shared_degenerate_samples(name):
    path = shared_gml(name)
    with pytest.raises(InputError, match=name):
        read_input(path)


# --- bad inputs --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("name", "problem"),
    [
        ("malformed.gml", "not well-formed XML"),
        ("empty.gml", "no pen-down points"),
        ("one_point.gml", "two distinct points"),
        ("same_points.gml", "two distinct points"),
        ("nan.gml", "NaN"),
        ("bad_number.gml", "not a number"),
        ("wrong_root.gml", "not <gml>"),
        ("truncated.json", "malformed or truncated"),
        ("no_gml.json", "not an object"),
        ("binary.gml", "not UTF-8"),
        ("malformed.svg", "could not be read"),
        ("empty.svg", "no paths"),
        ("degenerate.svg", "two distinct points"),
    ],
)
def test_bad_inputs_raise_input_error_naming_the_file(name, problem):
    with pytest.raises(InputError, match=problem) as err:
        read_input(data(name))
    message = str(err.value)
    assert message.startswith(data(name))
    assert message.count(". ") == 0 and message.endswith(".")  # one sentence


def test_empty_file(tmp_path):
    for suffix in (".gml", ".svg", ".json"):
        path = tmp_path / f"empty{suffix}"
        path.write_text("")
        with pytest.raises(InputError, match="empty"):
            read_input(str(path))


def test_oversized_file_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(gml, "MAX_FILE_BYTES", 100)
    monkeypatch.setattr(svg, "MAX_FILE_BYTES", 100)
    with pytest.raises(InputError, match="MB limit"):
        read_gml(data("tag.gml"))
    with pytest.raises(InputError, match="MB limit"):
        read_svg(data("shapes.svg"))


def test_too_many_points_refused(monkeypatch):
    monkeypatch.setattr(gml, "MAX_POINTS", 3)
    with pytest.raises(InputError, match="limit"):
        read_gml(data("tag.gml"))
    monkeypatch.setattr(svg, "MAX_POINTS", 10)
    with pytest.raises(InputError, match="limit"):
        read_svg(data("shapes.svg"))


# --- SVG ---------------------------------------------------------------------------------


def test_svg_subpaths_curves_and_transforms():
    t = read_svg(data("shapes.svg"))
    # path with 3 subpaths + translated closed quadratic + polyline
    assert len(t.strokes) == 5
    first, cubic, arc, quad, poly = t.strokes
    np.testing.assert_allclose(first, [[10, 10], [40, 10], [40, 40]])
    assert len(cubic) > 10 and len(arc) > 10  # curves flattened to many points
    np.testing.assert_allclose(cubic[[0, -1]], [[50, 50], [100, 50]], atol=1e-9)
    np.testing.assert_allclose(cubic[:, 1].min(), 27.5, atol=0.05)  # cubic's apex
    # arc: radius 20 about (130, 50), every sample on the circle
    np.testing.assert_allclose(np.hypot(arc[:, 0] - 130, arc[:, 1] - 50), 20, atol=1e-6)
    np.testing.assert_allclose(quad[0], [110, 80])  # translate(100 0) applied
    np.testing.assert_allclose(quad[-1], quad[0])  # Z closes the subpath
    np.testing.assert_allclose(poly, [[5, 95], [20, 90], [35, 95]])


def test_svg_of_filled_shapes_says_it_is_drawn_along_their_outlines(tmp_path: Path):
    """A logo exported as filled areas with no stroke: its outlines are the strokes, and
    the reader says so (the fit's report and console carry it as a warning)."""
    filled = tmp_path / "logo.svg"
    filled.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 50">'
                      '<path d="M 10 10 L 40 10 L 40 15 L 28 15 L 28 40 L 22 40 L 22 15 '
                      'L 10 15 Z" fill="black"/></svg>')
    t = read_svg(str(filled))
    assert len(t.strokes) == 1 and "outlines" in t.meta["notes"][0]
    assert "notes" not in read_svg(data("shapes.svg")).meta  # stroked: nothing to say


_SVG = '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 120 80">{}</svg>'
_LINES = ('<path d="M10 70L30 10L50 70" stroke="black" stroke-width="4" fill="none"/>'
          '<path d="M60 40L110 40" stroke="black" stroke-width="4"/>')


@pytest.mark.parametrize("paper, note", [
    # Figma's frame, matplotlib's figure patch: a white fill behind the lines
    ('<rect width="120" height="80" fill="white"/>', "its white filled shape (the paper's"),
    ('<path d="M0 80L120 80L120 0L0 0z" style="fill: #ffffff"/>', "white filled shape"),
    # a page of another colour behind the lines, and a white highlight among them
    ('<rect x="-5" y="-5" width="130" height="90" fill="#203040"/>', "its background"),
    ('<circle cx="60" cy="40" r="5" fill="#fafafa"/>', "white filled shape"),
])
def test_svg_paper_is_not_ink(tmp_path: Path, paper: str, note: str):
    """A white-filled page or highlight, or a filled background behind every line, was
    drawn as strokes (a frame round the drawing that shrank it); it is left out, said."""
    f = tmp_path / "export.svg"
    f.write_text(_SVG.format(paper + _LINES))
    t = read_svg(str(f))
    assert len(t.strokes) == 2 and note in " ".join(t.meta["notes"])
    np.testing.assert_allclose(t.strokes[0][0], [10, 70])
    only_white = tmp_path / "white.svg"  # nothing else painted: the white shape is the drawing
    only_white.write_text(_SVG.format('<circle cx="60" cy="40" r="5" fill="white"/>'))
    assert len(read_svg(str(only_white)).strokes) == 1
    filled_logo = tmp_path / "logo.svg"  # no line art: a filled shape is no background
    filled_logo.write_text(_SVG.format('<rect width="120" height="80" fill="black"/>'
                                       '<circle cx="60" cy="40" r="5" fill="red"/>'))
    assert len(read_svg(str(filled_logo)).strokes) == 2


@pytest.mark.parametrize("body, said", [
    ('<g style="display:none">' + _LINES + '</g>', "every shape of the SVG is hidden"),
    ('<g visibility="hidden">' + _LINES + '</g>', "every shape of the SVG is hidden"),
    ('<path d="hello" stroke="black"/>', "a path's data is not valid SVG path data "
                                         '(d="hello")'),
])
def test_svg_refusals_say_what_is_wrong(tmp_path: Path, body: str, said: str):
    f = tmp_path / "bad.svg"
    f.write_text(_SVG.format(body))
    with pytest.raises(InputError, match=re.escape(said)):
        read_svg(str(f))
    page = tmp_path / "page.svg"  # an HTML page saved with an .svg name
    page.write_text('<html xmlns="http://www.w3.org/1999/xhtml"><body>hi</body></html>')
    with pytest.raises(InputError, match="XML but not an SVG"):
        read_svg(str(page))


def test_svgz_and_collapsed_shapes(tmp_path: Path):
    """Inkscape's compressed .svgz is read (it was refused as no reader's); a shape with
    visibility: collapse is hidden, as with hidden."""
    import gzip

    from inkmotion.kinds.read import read_input

    f = tmp_path / "drawing.svgz"
    f.write_bytes(gzip.compress(_SVG.format(
        _LINES + '<path d="M0 0L5 5" stroke="black" visibility="collapse"/>').encode()))
    assert len(read_input(str(f)).strokes) == 2


def test_dots_are_drawn_as_dabs_in_their_place(tmp_path: Path):
    """A zero-length subpath (an SVG's round-cap dot) and a one-point GML stroke (a tap)
    were dropped without a word; each is a dab now, where it was in the drawing order."""
    f = tmp_path / "i.svg"
    f.write_text(_SVG.format('<path d="M20 10 Z M20 30 L20 70" stroke="black" '
                             'stroke-linecap="round"/>'))
    t = read_svg(str(f))
    assert [len(s) for s in t.strokes] == [2, 2]
    np.testing.assert_allclose(t.strokes[0], [[20, 10], [20 + 0.003 * 60, 10]])
    assert "its dot (a stroke of one point, a tap of the pen) is drawn as a dab" in \
        t.meta["notes"][0]
    g = tmp_path / "tap.gml"
    g.write_text("<gml><tag><drawing><stroke><pt><x>0.5</x><y>0.5</y><t>0</t></pt></stroke>"
                 "<stroke><pt><x>0.2</x><y>0.1</y><t>0.1</t></pt><pt><x>0.2</x><y>0.9</y>"
                 "<t>0.3</t></pt></stroke></drawing></tag></gml>")
    t = gml.read_gml(str(g))
    assert [len(s) for s in t.strokes] == [2, 2] and [len(x) for x in t.meta["t"]] == [2, 2]


def test_svg_nested_transform():
    t = read_svg(data("transformed.svg"))
    np.testing.assert_allclose(t.strokes[0], [[50, 50], [70, 50]])


@pytest.mark.parametrize("shape", [
    '<circle cx="0" cy="0" r="20"/>', '<ellipse cx="0" cy="0" rx="20" ry="20"/>',
    '<rect x="-14" y="-14" width="28" height="28"/>'])
def test_svg_basic_shapes_in_a_rotated_group_are_drawn_where_shown(tmp_path: Path,
                                                                  shape: str):
    """A circle, an ellipse or a rectangle in a rotated, scaled group (Inkscape writes
    such transforms): svgelements cannot make it a shape again, so it keeps the transform
    aside as a matrix; the strokes are the shape where the SVG shows it, as a path with
    the same transform is (they were drawn untransformed, at the origin)."""
    def strokes(element: str) -> np.ndarray:
        svg = tmp_path / "s.svg"
        svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 400 200" '
                       'width="200mm" height="100mm"><g transform="translate(300 100) '
                       f'rotate(30) scale(2 1)" fill="none" stroke="black">{element}</g>'
                       '<path d="M 10 10 L 60 10" stroke="black"/></svg>')
        return np.vstack(read_svg(str(svg)).strokes[0])

    shown = strokes(shape)
    centre = np.array([300.0, 100.0]) * 200 / 400 * 96 / 25.4  # user units to px
    turn = np.radians(30)
    rel = (shown - centre) @ np.array([[np.cos(turn), -np.sin(turn)],
                                       [np.sin(turn), np.cos(turn)]])  # turned back
    assert np.abs(rel).max() > 50  # scaled 2:1 about the group's origin (half-width 53 px)
    if "rect" in shape:
        np.testing.assert_allclose(np.abs(rel).max(axis=0), [14 * 2, 14] * np.array(
            200 / 400 * 96 / 25.4), rtol=1e-4)
    else:  # an ellipse 2:1 about the group's origin
        x, y = rel.T / (200 / 400 * 96 / 25.4)
        np.testing.assert_allclose(np.hypot(x / 2, y), 20, rtol=1e-3)


def test_svg_shapes_that_paint_nothing_are_not_drawn(tmp_path: Path):
    """A construction line with no stroke or fill, a guide of opacity 0 (on itself or on
    its group) and a fully transparent stroke are not part of the drawing (they were
    fitted like the lines); a shape with only a fill is still an outline to draw."""
    svg = tmp_path / "guides.svg"
    svg.write_text(
        '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
        '<path d="M 10 10 L 90 10" stroke="black" fill="none"/>'
        '<path d="M 10 20 L 90 20" stroke="none" fill="none"/>'
        '<path d="M 10 30 L 90 30" stroke="black" opacity="0"/>'
        '<g opacity="0"><path d="M 10 40 L 90 40" stroke="black"/></g>'
        '<path d="M 10 50 L 90 50" stroke="black" stroke-opacity="0" fill="none"/>'
        '<rect x="10" y="60" width="80" height="10" fill="red"/></svg>')
    starts = [s[0].tolist() for s in read_svg(str(svg)).strokes]
    assert starts == [[10, 10], [10, 60]]
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
                   '<path d="M 10 20 L 90 20" stroke="none" fill="none"/></svg>')
    with pytest.raises(InputError, match="every shape of the SVG is invisible"):
        read_svg(str(svg))


def test_svg_text_and_images_left_undrawn_are_named(tmp_path: Path):
    """Text that is still text and an embedded picture are not drawn; the reader says so
    and how to draw them (the fit carries it as a warning), so nothing vanishes silently."""
    svg = tmp_path / "card.svg"
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
                   '<path d="M 10 10 L 90 10" stroke="black"/>'
                   '<text x="10" y="50">Hi</text><text x="10" y="70">there</text>'
                   '<image x="0" y="80" width="20" height="20" href="pic.png"/></svg>')
    (note,) = read_svg(str(svg)).meta["notes"]
    assert note.startswith("its 2 text elements and 1 image are not drawn")
    assert "Object to Path" in note and "file of its own" in note
    assert "notes" not in read_svg(data("shapes.svg")).meta


def test_flatten_segment_tolerance():
    def circle(ts):
        return np.stack([np.cos(np.pi * ts), np.sin(np.pi * ts)], axis=1)

    pts = flatten_segment(circle, 1e-4)
    mids = (pts[:-1] + pts[1:]) / 2
    assert np.all(1 - np.hypot(mids[:, 0], mids[:, 1]) < 1.1e-4)


# --- text --------------------------------------------------------------------------------


def test_text_word_renders_connected_strokes():
    t = read_input("text:hello")
    assert 1 <= len(t.strokes) <= 5  # cursive: letters join into a few pen-down polylines
    lo, hi = bbox(t)
    width, height = hi - lo
    assert width > 2 * height  # a word is wider than tall
    assert t.meta["text"] == "hello"


def test_text_y_down_and_letter_spacing():
    one = render_text("l")
    two = render_text("ll")
    (lo1, hi1), (lo2, hi2) = bbox(one), bbox(two)
    assert 1.5 * (hi1 - lo1)[0] < (hi2 - lo2)[0]  # the second letter sits beside the first
    assert render_text("lI", spacing=10.0).n_points == render_text("lI").n_points
    # ascender of 'l' lies above (smaller y than) the end of the stroke on the baseline
    stroke = one.strokes[0]
    assert stroke[:, 1].min() < stroke[-1, 1]


@pytest.mark.parametrize(
    ("source", "problem"), [("text:", "empty"), ("text:   ", "empty"), ("text:naïve", "no glyph"),
                            ("text:東京", "no glyph for '東京'")]  # the missing, as written
)
def test_text_errors(source, problem):
    with pytest.raises(InputError, match=problem) as err:
        read_input(source)
    assert str(err.value).startswith(source)


# --- dispatch ----------------------------------------------------------------------------


def test_read_input_dispatch():
    assert read_input(data("tag.gml")).meta["format"] == "gml"
    assert read_input(data("tag.jsonp")).meta["format"] == "gml"
    assert read_input(data("shapes.svg")).meta["format"] == "svg"
    assert read_input("text:ink").meta["format"] == "text"


def test_can_read():
    assert GmlReader().can_read("a/b.GML") and GmlReader().can_read("x.json")
    assert not GmlReader().can_read("text:tag.gml")
    assert SvgReader().can_read("x.svg") and not SvgReader().can_read("x.gml")
    assert HersheyTextReader().can_read("text:x") and not HersheyTextReader().can_read("x.svg")
    assert hershey.SCHEME == "text:"


def test_missing_file():
    with pytest.raises(InputError, match="no such file") as err:
        read_input(data("does_not_exist.gml"))
    assert data("does_not_exist.gml") in str(err.value)


def test_unknown_form_lists_supported_forms(tmp_path):
    path = tmp_path / "drawing.xyz"
    path.write_text("hello")
    for source in (str(path), "caption:a cat"):
        with pytest.raises(InputError, match="no reader accepts") as err:
            read_input(source)
        message = str(err.value)
        assert message.startswith(source)
        for name in ("gml", "svg", "text"):
            assert name in message


def test_svg_symbols_are_drawn_where_used_and_sized_as_used(tmp_path: Path):
    """A <symbol> was drawn where it was defined (an unused one too) and at its own size
    whatever the <use> asked; a <line> with no stroke (invisible) was drawn."""
    f = tmp_path / "symbols.svg"
    f.write_text('<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/'
                 'xlink" viewBox="0 0 300 120"><symbol id="s" viewBox="0 0 60 100"><path '
                 'd="M0 0 V100" stroke="black"/></symbol><symbol id="unused" viewBox="0 0 10 10">'
                 '<circle cx="5" cy="5" r="4" stroke="black"/></symbol>'
                 '<use xlink:href="#s" x="0" y="0" width="30" height="50"/>'
                 '<use href="#s" x="100" y="0" width="120" height="100"/>'
                 '<line x1="0" y1="110" x2="150" y2="110"/></svg>')
    t = read_svg(str(f))
    assert len(t.strokes) == 2
    np.testing.assert_allclose(t.strokes[0], [[0, 0], [0, 50]])  # half size
    np.testing.assert_allclose(t.strokes[1], [[130, 0], [130, 100]])  # centred, meet


def test_svg_percentages_are_shares_of_the_right_side(tmp_path: Path):
    """svgelements took x="10%" of the height and y="10%" of the width (a circle at
    cx="50%" cy="50%" of a 400 × 200 page landed at (100, 200), off the page)."""
    f = tmp_path / "percent.svg"
    f.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="400" height="200">'
                 '<rect x="10%" y="10%" width="50%" height="25%" fill="none" stroke="black"/>'
                 '<line x1="0" y1="50%" x2="100%" y2="50%" stroke="black"/></svg>')
    rect, line = read_svg(str(f)).strokes
    np.testing.assert_allclose(rect.min(0), [40, 20])
    np.testing.assert_allclose(rect.max(0), [240, 70])
    np.testing.assert_allclose(line, [[0, 100], [400, 100]])


def test_a_gml_tag_without_a_header_is_on_the_screen_of_the_tag_before_it(tmp_path: Path):
    """A second <tag> with no header was read at scale 1 (its points in 0..1) beside a first
    tag scaled to its 1024 × 768 screen: it shrank to a dot."""
    g = tmp_path / "two.gml"
    stroke = ("<stroke><pt><x>0.1</x><y>0.1</y></pt><pt><x>0.5</x><y>0.1</y></pt></stroke>")
    g.write_text("<gml><tag><header><environment><screenBounds><x>1000</x><y>500</y>"
                 f"</screenBounds></environment></header><drawing>{stroke}</drawing></tag>"
                 f"<tag><drawing>{stroke}</drawing></tag></gml>")
    first, second = read_gml(str(g)).strokes
    np.testing.assert_allclose(second, first)


def test_svg_css_rules_that_nest_apply(tmp_path: Path):
    """`.sketch path {display:none}` hid nothing (svgelements applies only rules of one
    compound selector): the sketch layer was drawn. Nested rules (descendant and child)
    now apply; an element's own style still wins."""
    f = tmp_path / "css.svg"
    f.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 200 120"><style>'
                 '/* layers */ .sketch path{display:none} g.ink > path{fill:none;stroke:black}'
                 '</style><g class="ink"><path d="M0 0 V100"/><path d="M5 0 V100" '
                 'style="stroke:none"/></g><g class="sketch"><g><path d="M100 0 L160 100" '
                 'stroke="black"/></g></g></svg>')
    (stroke,) = read_svg(str(f)).strokes
    np.testing.assert_allclose(stroke, [[0, 0], [0, 100]])


def _timed_gml(path: Path, strokes: list[list[tuple[float, float, float | None]]],
               header: str = "") -> str:
    """A GML file of ``strokes`` of (x, y, t) points; t None: no <t>."""
    body = "".join("<stroke>" + "".join(
        f"<pt><x>{x}</x><y>{y}</y>{'' if t is None else f'<t>{t}</t>'}</pt>"
        for x, y, t in st) + "</stroke>" for st in strokes)
    path.write_text(f"<gml><tag>{header}<drawing>{body}</drawing></tag></gml>")
    return str(path)


def test_a_gml_screen_of_negative_size_is_refused_and_half_a_screen_squashes_nothing(
        tmp_path: Path):
    """screenBounds y = -600 was read as 1 beside x = 1000: the drawing was squashed to a
    line and its fit rated good. A negative size is refused; a missing or zero axis leaves
    both unscaled (one axis scaled alone squashes the drawing)."""
    square = [[(0.1, 0.1, None), (0.5, 0.1, None), (0.5, 0.5, None), (0.1, 0.5, None)]]

    def bounds(x: str, y: str) -> str:
        return (f"<header><environment><screenBounds><x>{x}</x><y>{y}</y></screenBounds>"
                "</environment></header>")

    with pytest.raises(InputError, match="screenBounds y is -600.*cannot be negative"):
        read_gml(_timed_gml(tmp_path / "neg.gml", square, bounds("1000", "-600")))
    for name, header in (("zero", bounds("1000", "0")), ("one", bounds("1000", ""))):
        (stroke,) = read_gml(_timed_gml(tmp_path / f"{name}.gml", square, header)).strokes
        extent = stroke.max(0) - stroke.min(0)
        assert extent[0] == pytest.approx(extent[1]), name


def test_a_few_points_without_time_stamps_are_filled_in_and_many_drop_the_times(
        tmp_path: Path):
    """One point of a thousand without <t> threw all the recording's times away without a
    word. A few are filled in from their neighbours (and counted); more leave no times,
    with the count of points that had none."""
    wave = [(0.1 + 0.001 * i, 0.5 + 0.1 * np.sin(i / 50)) for i in range(400)]
    stamps: list[float | None] = [0.005 * i for i in range(400)]
    stamps[200] = None
    traces = read_gml(_timed_gml(tmp_path / "one.gml", [[(x, y, t) for (x, y), t in
                                                          zip(wave, stamps, strict=True)]]))
    assert traces.meta["times_filled"] == 1
    assert traces.meta["t"][0][200] == pytest.approx(1.0)
    many = [None if i % 3 == 0 else t for i, t in enumerate(stamps)]
    traces = read_gml(_timed_gml(tmp_path / "many.gml", [[(x, y, t) for (x, y), t in
                                                           zip(wave, many, strict=True)]]))
    assert "t" not in traces.meta and traces.meta["times_missing"] == 135


def test_the_gml_readers_time_unit_is_recorded_when_declared(tmp_path: Path):
    from inkmotion.kinds.read import read_input

    source = _timed_gml(tmp_path / "s.gml", [[(0.1, 0.1, 0.0), (0.5, 0.1, 1.0),
                                              (0.5, 0.5, 2.0)]])
    assert "time_unit" not in read_input(source).meta
    assert read_input(source, "gml", {"time_unit": "ms"}).meta["time_unit"] == "ms"


def test_an_svg_switch_draws_only_the_child_a_viewer_draws(tmp_path: Path):
    """svgelements drew every child of a <switch>: each language's version of a label, and
    Illustrator's private copy beside its drawing. The first child whose conditions hold
    is drawn: no extension is supported, the language is English."""
    f = tmp_path / "switch.svg"
    f.write_text(
        '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 200 100"><switch>'
        '<foreignObject requiredExtensions="http://ns.adobe.com/AdobeIllustrator/10.0/">'
        '<path d="M0 0 L10 10" stroke="black"/></foreignObject>'
        '<g systemLanguage="fr"><path d="M10 10 L190 10" stroke="black"/></g>'
        '<g systemLanguage="de, en-GB"><path d="M10 50 L190 50" stroke="black"/></g>'
        '<g><path d="M10 90 L190 90" stroke="black"/></g></switch>'
        '<path d="M100 0 V100" stroke="black"/></svg>')
    english, after = read_svg(str(f)).strokes
    np.testing.assert_allclose(english, [[10, 50], [190, 50]])
    np.testing.assert_allclose(after, [[100, 0], [100, 100]])


def test_an_svg_clip_path_cuts_what_it_clips(tmp_path: Path):
    """svgelements applies no clip path: a matplotlib line clipped to its axes, or art cut
    by a Figma frame, was drawn whole. The part inside is drawn, in the clipped element's
    coordinates (its transform, and its ancestors'), nested clips intersected; a clip in
    objectBoundingBox units or one that is missing leaves the path whole."""
    f = tmp_path / "clip.svg"
    f.write_text(
        '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 300 200"><g>'
        '<path d="M0 195 L300 195" stroke="black" clip-path="url(#late)"/></g>'
        '<defs><clipPath id="c"><rect x="0" y="0" width="50" height="100"/></clipPath>'
        '<clipPath id="bb" clipPathUnits="objectBoundingBox"><rect width=".5" height="1"/>'
        '</clipPath><clipPath id="low"><rect x="0" y="60" width="300" height="140"/>'
        '</clipPath></defs>'
        '<g transform="translate(100 0)" clip-path="url(#c)">'
        '<path d="M-20 50 L30 50 L30 20 L80 20" stroke="black" fill="none"/></g>'
        '<g transform="scale(2)"><g clip-path="url(#c)"><path d="M10 10 L10 45" '
        'stroke="black"/></g></g>'
        '<g clip-path="url(#low)"><path d="M200 0 V200" stroke="black" '
        'style="clip-path: url(\'#c\')"/><path d="M60 0 V120" stroke="black"/></g>'
        '<path d="M0 150 L300 150" stroke="black" clip-path="url(#bb)"/>'
        '<path d="M0 160 L300 160" stroke="black" clip-path="url(#nowhere)"/>'
        '<clipPath id="late"><circle cx="150" cy="195" r="20"/></clipPath></svg>')
    strokes = [s.round(6).tolist() for s in read_svg(str(f)).strokes]
    assert strokes == [
        [[130, 195], [170, 195]],  # a clip path defined after its use (matplotlib's)
        [[100, 50], [130, 50], [130, 20], [150, 20]],  # in the group's translated space
        [[20, 20], [20, 90]],  # the clip scaled with its group: inside
        [[60, 60], [60, 120]],  # #low alone; the line at x 200 is outside #c
        [[0, 150], [300, 150]], [[0, 160], [300, 160]]]  # not applied: drawn whole


def test_an_illustrator_clip_group_cuts_its_art(tmp_path: Path):
    """Illustrator's clip group: the clip path a <use> of a shape in <defs>."""
    f = tmp_path / "ai.svg"
    f.write_text('<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999'
                 '/xlink" viewBox="0 0 200 200"><g><defs><rect id="SVGID_1_" x="20" y="20" '
                 'width="100" height="100"/></defs><clipPath id="SVGID_2_"><use xlink:href='
                 '"#SVGID_1_" overflow="visible"/></clipPath><g clip-path="url(#SVGID_2_)">'
                 '<path fill="none" stroke="#000" d="M0 70 L200 70"/></g></g></svg>')
    (stroke,) = read_svg(str(f)).strokes
    np.testing.assert_allclose(stroke, [[20, 70], [120, 70]])


def test_an_svg_whose_every_path_is_clipped_away_says_so(tmp_path: Path):
    f = tmp_path / "away.svg"
    f.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100"><defs>'
                 '<clipPath id="c"><rect width="10" height="10"/></clipPath></defs>'
                 '<path d="M50 50 L90 90" stroke="black" clip-path="url(#c)"/></svg>')
    with pytest.raises(InputError, match="draw nothing"):
        read_svg(str(f))


def test_inputs_that_would_hang_or_exhaust_memory_are_one_sentence(tmp_path: Path):
    """Found by fuzzing: 100 000 two-point strokes (within the point limit) took minutes to
    count and then the fit's memory; 10 000 nested groups raised Python's RecursionError
    into the message; a pipe was 'no such file'."""
    import os

    from inkmotion.geometry.traces import MAX_STROKES, Traces

    many = [np.array([[i, 0.0], [i, 1.0]]) for i in range(MAX_STROKES + 1)]
    with pytest.raises(InputError, match=f"{MAX_STROKES + 1} strokes is more than the limit"):
        Traces(many, source="many").validated()
    deep = tmp_path / "deep.svg"
    deep.write_text('<svg xmlns="http://www.w3.org/2000/svg">' + "<g>" * 5000
                    + '<path d="M0 0 L9 9" stroke="black"/>' + "</g>" * 5000 + "</svg>")
    with pytest.raises(InputError, match="nested too deeply to read") as err:
        read_svg(str(deep))
    assert "RecursionError" not in str(err.value)
    fifo = tmp_path / "pipe.gml"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match="is not a regular file"):
        read_gml(str(fifo))


def test_svgs_whose_parse_would_hang_are_refused_before_it(tmp_path: Path):
    """Fuzzing: ten <use> of ten of ten … (a 2-KB file, ten million shapes) and a 30-MB
    attribute (the XML parser's time grows with its square) ran for minutes."""
    fan = tmp_path / "fan.svg"
    levels = ['<g id="l0"><path d="M0 0 L10 10" stroke="black"/></g>'] + [
        f'<g id="l{k}">' + f'<use href="#l{k - 1}"/>' * 10 + "</g>" for k in range(1, 8)]
    fan.write_text('<svg xmlns="http://www.w3.org/2000/svg"><defs>' + "".join(levels)
                   + '</defs><use href="#l7"/></svg>')
    with pytest.raises(InputError, match="references expand to more than 1,000,000"):
        read_svg(str(fan))
    loop = tmp_path / "loop.svg"
    loop.write_text('<svg xmlns="http://www.w3.org/2000/svg"><g id="a"><use href="#b"/></g>'
                    '<g id="b"><use href="#a"/></g></svg>')
    with pytest.raises(InputError, match="refers, through others, to itself"):
        read_svg(str(loop))
    long = tmp_path / "long.svg"
    long.write_text('<svg xmlns="http://www.w3.org/2000/svg"><path stroke="black" d="M0 0'
                    + " L1 1" * 1_000_000 + '"/></svg>')
    with pytest.raises(InputError, match="an attribute of 5 MB is more than the 4 MB"):
        read_svg(str(long))
