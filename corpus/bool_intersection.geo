// OpenCASCADE boolean: intersection of a sphere and a box (curved and planar faces meeting at arcs).
SetFactory("OpenCASCADE");
DefineConstant[size = 0.25];
Sphere(1) = {0, 0, 0, 1};
Box(2) = {-0.7, -0.7, -0.7, 1.4, 1.4, 1.4};
BooleanIntersection{ Volume{1}; Delete; }{ Volume{2}; Delete; }
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
