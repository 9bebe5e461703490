// Two boxes separated by a gap much thinner than the mesh size, fragmented with a
// thin slab between them (thin volume, thin faces, shared walls).
SetFactory("OpenCASCADE");
DefineConstant[size = 0.25];
Box(1) = {0, 0, 0, 1, 1, 1};
Box(2) = {1, 0, 0, 0.02, 1, 1};
Box(3) = {1.02, 0, 0, 1, 1, 1};
BooleanFragments{ Volume{1, 2, 3}; Delete; }{}
Mesh.MeshSizeMax = size;
Physical Surface("all") = Surface{:};
