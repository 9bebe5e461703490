#!/usr/bin/env python3
"""Prints what Gmsh reads from an MSH file as canonical text lines, so that two
files can be compared line by line (tests/common/mod.rs, `gmsh_summary`).

Usage: gmsh_summary.py FILE [--no-element-tags] [--no-classification] [--round]

  nodes N SHA             node tags with exact coordinates (12 significant
                          digits with --round: Gmsh's ASCII writer keeps 16)
  node-entity D T N       nodes classified on entity (D, T)   [not with --no-classification]
  entity D T              every entity                         [with --no-classification:
                                                                only entities with elements]
  elements D T TYPE N SHA connectivity of the elements of that type on (D, T)
  element-tags SHA        all element tags with their nodes    [not with --no-element-tags]
  physical D T "NAME" E   physical groups with their entities
Exits 1 (message on stderr) when Gmsh reports an error while reading.
"""
import hashlib
import sys

import gmsh


def sha(items):
    h = hashlib.sha1()
    for item in items:
        h.update(repr(item).encode())
        h.update(b"\n")
    return h.hexdigest()[:16]


def plain(values):
    """A list of Python numbers (the gmsh module returns numpy arrays when numpy
    is installed, lists otherwise)."""
    return values.tolist() if hasattr(values, "tolist") else list(values)


def main(argv):
    path = argv[1]
    element_tags = "--no-element-tags" not in argv
    classification = "--no-classification" not in argv
    rounded = "--round" in argv
    gmsh.initialize(["gmsh_summary"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.logger.start()
    try:
        gmsh.open(path)
    except Exception as exc:
        print(f"{path}: {exc}", file=sys.stderr)
        return 1
    errors = [l for l in gmsh.logger.get() if l.startswith("Error")]
    if errors:
        print(f"{path}: {errors[0]}", file=sys.stderr)
        return 1
    lines = []
    nodes = []
    tagged = []
    for dim, tag in gmsh.model.getEntities():
        ntags, coords, _ = gmsh.model.mesh.getNodes(dim, tag, False, False)
        ntags, coords = plain(ntags), plain(coords)
        for i, t in enumerate(ntags):
            xyz = coords[3 * i:3 * i + 3]
            if rounded:
                xyz = ["%.12g" % c for c in xyz]
            nodes.append((int(t), *xyz))
        if classification:
            lines.append(f"node-entity {dim} {tag} {len(ntags)}")
        types, etags, enodes = gmsh.model.mesh.getElements(dim, tag)
        types, etags, enodes = plain(types), [plain(t) for t in etags], [plain(n) for n in enodes]
        if classification or len(types) > 0:
            lines.append(f"entity {dim} {tag}")
        for etype, et, en in zip(types, etags, enodes):
            k = len(en) // max(len(et), 1)
            conn = sorted(tuple(int(n) for n in en[i * k:(i + 1) * k]) for i in range(len(et)))
            lines.append(f"elements {dim} {tag} {etype} {len(et)} {sha(conn)}")
            tagged += [(int(t),) + tuple(int(n) for n in en[i * k:(i + 1) * k]) for i, t in enumerate(et)]
    nodes.sort()
    lines.insert(0, f"nodes {len(nodes)} {sha(nodes)}")
    if element_tags:
        tagged.sort()
        lines.append(f"element-tags {len(tagged)} {sha(tagged)}")
    for dim, tag in sorted(gmsh.model.getPhysicalGroups()):
        ents = sorted(int(e) for e in gmsh.model.getEntitiesForPhysicalGroup(dim, tag))
        lines.append(f'physical {dim} {tag} "{gmsh.model.getPhysicalName(dim, tag)}" {ents}')
    print("\n".join(lines))
    gmsh.finalize()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
