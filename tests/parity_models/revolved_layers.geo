If(!Exists(size)) size=0.3; EndIf
Point(1)={1,0,0,size}; Point(2)={2,0,0,size}; Point(3)={2.3,0,1,size}; Point(4)={1.2,0,1.5,size};
Line(1)={1,2}; Line(2)={2,3}; Line(3)={3,4}; Line(4)={4,1};
Curve Loop(1)={1,2,3,4}; Plane Surface(1)={1};
Extrude{{0,0,1},{0,0,0},Pi/2}{ Surface{1}; Layers{7}; Recombine; }
