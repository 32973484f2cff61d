"""The atlas as Blender shows copies of one mesh: each object whole on one page, copies of
one layout with the same charts shifted by whole texels, a slot at one offset within every
block it is in, and no two objects' triangles on one texel."""
from dataclasses import replace

import numpy as np

from native import PointLight
from native.atlas import build_atlas
from native.samples import SceneBuilder


def copies_scene():
    """Four copies of one box (a collection shown by two instancers, each holding the box
    and a plank), a plank alone, and a big floor."""
    builder = SceneBuilder()
    builder.quad("floor", [(-5, 0, -5), (-5, 0, 5), (5, 0, 5), (5, 0, -5)], (0.5,) * 3)
    names = []
    for index, x in enumerate((-3.0, 3.0)):
        for name, size in (("box", (0.6, 0.4, 0.5)), ("plank", (1.0, 0.2, 0.1))):
            corners = [(x, size[2], 0), (x + size[0], size[2], 0),
                       (x + size[0], size[2], size[1]), (x, size[2], size[1])]
            builder.box(f"E{index}/{name}", corners, 0.0, (0.5,) * 3)
            names.append((f"E{index}/{name}", name, f"E{index}"))
    builder.box("plank", [(0, .1, 3), (1, .1, 3), (1, .1, 3.2), (0, .1, 3.2)], 0.0, (0.5,) * 3)
    names.append(("plank", "plank", "plank"))
    scene = builder.build(lights=[PointLight((0.0, 2.0, 0.0), 100.0)])
    layout, slot, block = [], [], []
    for object_name in scene.object_names:
        entry = next((n for n in names if n[0] == object_name), None)
        mesh, owner = (entry[1], entry[2]) if entry else (object_name, object_name)
        layout.append(mesh)
        slot.append(mesh if entry and entry[2] != "plank" else object_name)
        block.append(owner)
    number = lambda keys: np.unique(keys, return_inverse=True)[1]
    return replace(scene, object_layout=number(layout), object_slot=number(slot),
                   object_block=number(block))


def object_texels(atlas, scene, name):
    obj = scene.object_names.index(name)
    rows = scene.object_index[atlas.triangles] == obj
    return atlas.texels[rows], atlas.page[rows], obj


def test_copies_share_charts_slots_keep_their_offset_and_nothing_overlaps():
    scene = copies_scene()
    atlas = build_atlas(scene, 20.0, max_size=128, padding=2, align=4)
    for mesh in ("box", "plank"):
        shapes = []
        for owner in ("E0", "E1"):
            texels, page, obj = object_texels(atlas, scene, f"{owner}/{mesh}")
            assert len(set(page)) == 1 and page[0] == atlas.object_page[obj]
            shift = texels - texels[0, 0]
            shapes.append(shift)
            # The texels are the object's origin plus its layout: whole texels apart.
            origin = atlas.object_origin[obj]
            assert np.allclose(origin, np.round(origin)) and (origin % 4 == 0).all()
        np.testing.assert_allclose(shapes[0], shapes[1], atol=1e-9)
    # A slot sits at one offset within both blocks; the blocks differ.
    for mesh in ("box", "plank"):
        offsets = [atlas.object_offset[scene.object_names.index(f"{owner}/{mesh}")]
                   for owner in ("E0", "E1")]
        np.testing.assert_array_equal(offsets[0], offsets[1])
    blocks = [atlas.object_origin[scene.object_names.index(f"{owner}/box")]
              - atlas.object_offset[scene.object_names.index(f"{owner}/box")]
              for owner in ("E0", "E1")]
    for owner, block in zip(("E0", "E1"), blocks):
        obj = scene.object_names.index(f"{owner}/plank")
        np.testing.assert_array_equal(atlas.object_origin[obj] - atlas.object_offset[obj],
                                      block)
    assert not np.array_equal(blocks[0], blocks[1])
    # No texel is held by two objects (texel boxes of each object's triangles).
    owner = np.full((atlas.page_count, atlas.height + 1, atlas.width + 1), -1)
    for obj in range(len(scene.object_names)):
        rows = scene.object_index[atlas.triangles] == obj
        for corners, page in zip(atlas.texels[rows], atlas.page[rows]):
            x0, y0 = np.floor(corners.min(axis=0) + 1e-6).astype(int)
            x1, y1 = np.ceil(corners.max(axis=0) - 1e-6).astype(int)
            held = owner[page, y0:y1, x0:x1]
            assert np.isin(held, [-1, obj]).all()
            owner[page, y0:y1, x0:x1] = obj


def test_each_object_is_whole_on_one_page_when_the_atlas_takes_several():
    scene = copies_scene()
    atlas = build_atlas(scene, 20.0, max_size=512, padding=2)
    small = build_atlas(scene, 5.0, max_size=64, padding=2)
    assert atlas.page_count == 1 and small.page_count > 1
    for obj in range(len(scene.object_names)):
        rows = scene.object_index[small.triangles] == obj
        assert len(set(small.page[rows])) == 1
        assert (small.texels[rows] >= 0).all()
        assert (small.texels[rows] <= [small.width, small.height]).all()
