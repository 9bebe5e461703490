SetFactory("OpenCASCADE");
If(!Exists(size)) size=0.3; EndIf
Box(1)={0,0,0,2,1.5,1}; Cylinder(2)={1,0.75,-0.5,0,0,2,0.4};
BooleanDifference{Volume{1};Delete;}{Volume{2};Delete;}
Mesh.MeshSizeMax=size;
