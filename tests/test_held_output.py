"""``common.held_output``: what C code prints past ``sys.stdout`` held for a block, written out
after it less the dropped lines, or not at all for a failed block that asks so."""

import os

import pytest

from porous_weathering.common import held_output


def test_lines_are_written_after_the_block_less_the_dropped(capfd):
    with held_output.held((b"Info: noise",)):
        os.write(1, b"kept 1\nInfo: noise of a bake\nkept 2\n")
        os.write(2, b"Info: noise on stderr\nan error\n")
        assert capfd.readouterr() == ("", "")  # held until the block ends
    assert capfd.readouterr() == ("kept 1\nkept 2\n", "an error\n")
    os.write(1, b"after\n")  # the descriptors given back
    assert capfd.readouterr().out == "after\n"


@pytest.mark.parametrize("shown", [True, False])
def test_a_failed_block_shows_its_output_only_if_asked(capfd, shown):
    with pytest.raises(RuntimeError), held_output.held(shown_on_error=shown):
        os.write(1, b"traceback\n")
        raise RuntimeError("failed")
    assert capfd.readouterr().out == ("traceback\n" if shown else "")
