MODULE BurrHoles
  ! The phantom's burr-hole entries touched with the pointer, programmed on the
  ! virtual cell: the work object on the phantom's nominal pose (table at 0).
  PERS tooldata tPointer := [TRUE,[[0,0,200],[1,0,0,0]],[2,[0,0,100],[1,0,0,0],0,0,0]];
  PERS wobjdata wobjPhantom := [FALSE,TRUE,"",[[1150,0,512.0851],[0.5,0,0,0.8660254]],[[0,0,0],[1,0,0,0]]];
  CONST speeddata vTouch := [20,500,5000,1000];
  CONST robtarget pApp0 := [[45.8622,-28.5852,128.4381],[0.06623914,-0.9904213,-0.00808462,0.12088284],[0,-1,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pTouch0 := [[31.431,-20.8299,70.7181],[0.06623914,-0.9904213,-0.00808462,0.12088284],[0,-1,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pApp1 := [[45.8596,28.5837,128.4282],[0.06623857,0.99042142,-0.0080845,-0.12088216],[0,-1,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pTouch1 := [[31.4284,20.8285,70.7082],[0.06623857,0.99042142,-0.0080845,-0.12088216],[0,-1,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pApp2 := [[-56.6566,-47.9499,123.1015],[0.12798461,-0.97313794,0.02495361,-0.18973614],[-1,0,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pTouch2 := [[-34.1166,-33.5725,69.3871],[0.12798461,-0.97313794,0.02495361,-0.18973614],[-1,0,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pApp3 := [[-109.4847,37.0289,98.5671],[0.1160307,0.9283893,0.04378131,0.3503047],[-1,0,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pTouch3 := [[-69.8488,25.9427,54.9083],[0.1160307,0.9283893,0.04378131,0.3503047],[-1,0,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  PROC main()
    ConfJ\Off;
    ConfL\Off;
    ! kocher_right
    MoveJ pApp0, v500, z10, tPointer\WObj:=wobjPhantom;
    MoveL pTouch0, vTouch, fine, tPointer\WObj:=wobjPhantom;
    MoveL pApp0, v100, z10, tPointer\WObj:=wobjPhantom;
    ! kocher_left
    MoveJ pApp1, v500, z10, tPointer\WObj:=wobjPhantom;
    MoveL pTouch1, vTouch, fine, tPointer\WObj:=wobjPhantom;
    MoveL pApp1, v100, z10, tPointer\WObj:=wobjPhantom;
    ! parietal_right
    MoveJ pApp2, v500, z10, tPointer\WObj:=wobjPhantom;
    MoveL pTouch2, vTouch, fine, tPointer\WObj:=wobjPhantom;
    MoveL pApp2, v100, z10, tPointer\WObj:=wobjPhantom;
    ! occipital_left
    MoveJ pApp3, v500, z10, tPointer\WObj:=wobjPhantom;
    MoveL pTouch3, vTouch, fine, tPointer\WObj:=wobjPhantom;
    MoveL pApp3, v100, z10, tPointer\WObj:=wobjPhantom;
  ENDPROC
ENDMODULE
