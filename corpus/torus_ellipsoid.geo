// OpenCASCADE torus and an ellipsoid (sphere scaled by Dilate): doubly curved faces with seams.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.2];
Torus(1) = {0, 0, 0, 1, 0.3};
Sphere(2) = {3, 0, 0, 1};
Dilate{{3, 0, 0}, {1, 0.5, 0.3}}{ Volume{2}; }
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
