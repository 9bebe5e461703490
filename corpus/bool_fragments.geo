// OpenCASCADE BooleanFragments: a box and a cylinder crossing it, giving several volumes
// with shared internal faces (every face belongs to one physical group).
SetFactory("OpenCASCADE");
DefineConstant[size = 0.3];
Box(1) = {0, 0, 0, 1, 1, 1};
Cylinder(2) = {0.5, 0.5, -0.5, 0, 0, 2, 0.3};
BooleanFragments{ Volume{1, 2}; Delete; }{}
Mesh.MeshSizeMax = size;
Physical Surface("faces") = Surface{:};
