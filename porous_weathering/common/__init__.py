"""Plumbing the layers share, without bpy: options declared once for every front end
(``options``), files written whole or not at all (``atomic``), a command line that stops at
once on SIGINT/SIGTERM (``interrupts``), map images on disk through OpenImageIO (``imageio``), the
text progress bar (``progress``), the process's own output held for a block (``held_output``) and
its end at once with nothing left behind (``process_end``).

May import: the standard library, numpy, OpenImageIO and ``core``; never bpy.
"""
