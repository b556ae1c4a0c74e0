"""The nodes of shading.py's materials: how many a material's shader holds, its groups' included
(``bench_stone_cost.node_count``), and each group's own (docs/benchmarks.md, "On every map the
modes read"), the noise-free count beside shading_instructions.py's instructions.

    python benchmarks/shading_nodes.py [--materials NAME ...]

Prints one line per material, then one per node group it holds.
"""

import argparse
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import bpy  # noqa: E402

from benchmarks import bench_stone_cost, shading  # noqa: E402

DEFAULT_MATERIALS = (
    "all three modes, key light, baked maps",
    shading.STRUCTURED,
    shading.ON_EVERY_MAP,
    shading.STRUCTURED_ON_EVERY_MAP,
)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--materials", nargs="+", default=DEFAULT_MATERIALS, help="shading.py's names")
    args = parser.parse_args()
    _, _, sun, _ = shading.scene_filling_the_frame(8)
    makers = shading.material_makers(sun)
    for name in args.materials:
        material = makers[name]()
        print(f"{name}: {bench_stone_cost.node_count(material)} nodes")
        for node in material.node_tree.nodes:
            if node.type == "GROUP" and node.node_tree:
                print(f"    {node.node_tree.name}: {len(node.node_tree.nodes)} nodes")
    bpy.ops.wm.read_factory_settings(use_empty=True)


if __name__ == "__main__":
    main()
