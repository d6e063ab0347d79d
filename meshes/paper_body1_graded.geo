// Body 1 of the paper's scene (labels as paper_body1.geo: 1 Γ_C, 2 right, 3 top x ≥ 3, 4 top x ≤ 3,
// 5 left), meshed finer toward the points where the solution is singular: the clamped corners
// (0,0) and (0,6), the load jump (3,6), the end (6,0) of Γ_C and the edge of the contact zone
// near (3.75,0). The size grows linearly from fine·h at those points to h = 6/n at distance radius.
// Refining this mesh by splitting every triangle in four (scene key mesh.refine) keeps the
// grading and gives nested meshes, so convergence and the benchmark measure errors exactly.
DefineConstant[ n = 6, fine = 0.12, radius = 2.5 ];
h = 6 / n;
Point(1) = {0, 0, 0, h};
Point(2) = {6, 0, 0, h};
Point(3) = {6, 6, 0, h};
Point(4) = {3, 6, 0, h};
Point(5) = {0, 6, 0, h};
Point(6) = {3.75, 0, 0, h};
Line(1) = {1, 6};
Line(6) = {6, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 5};
Line(5) = {5, 1};
Curve Loop(1) = {1, 6, 2, 3, 4, 5};
Plane Surface(1) = {1};
Field[1] = Distance;
Field[1].PointsList = {1, 2, 4, 5, 6};
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = fine * h;
Field[2].SizeMax = h;
Field[2].DistMin = 0;
Field[2].DistMax = radius;
Background Field = 2;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeExtendFromBoundary = 0;
Physical Curve(1) = {1, 6};
Physical Curve(2) = {2};
Physical Curve(3) = {3};
Physical Curve(4) = {4};
Physical Curve(5) = {5};
Physical Surface(1) = {1};
Mesh.MshFileVersion = 2.2;
Mesh.Binary = 0;
