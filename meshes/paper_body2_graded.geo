// Body 2 of the paper's scene (labels as paper_body2.geo: 1 Γ_C, 2 right, 3 bottom, 4 left),
// meshed finer toward the ends (0,0) and (6,0) of Γ_C, the edge of the contact zone near
// (3.75,0) and the corner (6,−6) where the free side meets the clamped bottom. The size grows
// linearly from fine·h there to h = 6/n at distance radius; see paper_body1_graded.geo.
DefineConstant[ n = 8, fine = 0.12, radius = 2.5 ];
h = 6 / n;
Point(1) = {0, 0, 0, h};
Point(2) = {0, -6, 0, h};
Point(3) = {6, -6, 0, h};
Point(4) = {6, 0, 0, h};
Point(5) = {3.75, 0, 0, h};
Line(1) = {4, 5};
Line(5) = {5, 1};
Line(2) = {3, 4};
Line(3) = {2, 3};
Line(4) = {1, 2};
Curve Loop(1) = {1, 5, 4, 3, 2};
Plane Surface(1) = {1};
Field[1] = Distance;
Field[1].PointsList = {1, 3, 4, 5};
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = fine * h;
Field[2].SizeMax = h;
Field[2].DistMin = 0;
Field[2].DistMax = radius;
Background Field = 2;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeExtendFromBoundary = 0;
Physical Curve(1) = {1, 5};
Physical Curve(2) = {2};
Physical Curve(3) = {3};
Physical Curve(4) = {4};
Physical Surface(1) = {1};
Mesh.MshFileVersion = 2.2;
Mesh.Binary = 0;
