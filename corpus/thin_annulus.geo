// Planar: two nearly coincident circles and an eccentric one (a thin annulus and a crescent
// whose width goes to a few percent of the mesh size).
SetFactory("OpenCASCADE");
DefineConstant[size = 0.15];
Disk(1) = {0, 0, 0, 1};
Disk(2) = {0, 0, 0, 0.97};
Disk(3) = {0.05, 0, 0, 0.9};
BooleanFragments{ Surface{1}; Delete; }{ Surface{2, 3}; Delete; }
Mesh.MeshSizeMax = size;
Physical Surface("all") = Surface{:};
