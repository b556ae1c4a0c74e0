"""``common.held_output``: what C code prints past ``sys.stdout`` held for a block, written out
after it less the lines holding a dropped note, or not at all for a failed block that asks so."""

import os
from unittest import mock

import pytest

from porous_weathering.common import held_output


def test_lines_are_written_after_the_block_less_the_dropped(capfd):
    with held_output.held((b"Info: noise",)):
        os.write(1, b"kept 1\nInfo: noise of a bake\nkept 2\n00:00.499  log  | Info: noise after a time\n")
        os.write(2, b"Info: noise on stderr\nan error\n")
        assert capfd.readouterr() == ("", "")  # held until the block ends
    assert capfd.readouterr() == ("kept 1\nkept 2\n", "an error\n")
    os.write(1, b"after\n")  # the descriptors given back
    assert capfd.readouterr().out == "after\n"


def test_empty_lines_are_dropped_too(capfd):
    """Blender spaces its notes with empty lines (Blender 4 after each picture's "Time:"): alone,
    they would still break a progress bar's line."""
    with held_output.held((b"Time:",)):
        os.write(1, b"Time: 00:09.76 (Saving: 00:00.05)\n\n \nkept\n\n")
    assert capfd.readouterr().out == "kept\n"


@pytest.mark.parametrize("shown", [True, False])
def test_a_failed_block_shows_its_output_only_if_asked(capfd, shown):
    with pytest.raises(RuntimeError), held_output.held(shown_on_error=shown):
        os.write(1, b"traceback\n")
        raise RuntimeError("failed")
    assert capfd.readouterr().out == ("traceback\n" if shown else "")


def test_a_descriptor_that_cannot_be_held_is_left_as_it_is(capfd):
    """A program started without a console may have no descriptor 2 to duplicate: the block runs."""
    duplicate = os.dup

    def no_stderr(fd):
        if fd == 2:
            raise OSError(9, "Bad file descriptor")
        return duplicate(fd)

    # patched for the block alone: pytest's own capture duplicates descriptors too
    with mock.patch.object(os, "dup", no_stderr), held_output.held((b"Info",)):
        os.write(1, b"Info: dropped\nkept\n")
        os.write(2, b"as it comes\n")
    assert capfd.readouterr() == ("kept\n", "as it comes\n")


def test_given_back_in_the_middle_of_a_block(capfd):
    """A command ended by a signal during a block (``interrupts``) gives the descriptors back
    first: what was held is written, its last line goes straight out, and the block's end adds
    nothing twice."""
    with held_output.held((b"Info",)):
        os.write(1, b"before\nInfo: dropped\n")
        held_output.give_back()
        os.write(2, b"interrupted\n")
        assert capfd.readouterr() == ("before\n", "interrupted\n")
    assert capfd.readouterr() == ("", "")
