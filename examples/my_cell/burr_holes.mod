MODULE BurrHoles
  ! The phantom's burr-hole entries touched with the pointer, programmed on the
  ! virtual cell: the work object on the phantom's nominal pose (table at 0).
  PERS tooldata tPointer := [TRUE,[[0,0,200],[1,0,0,0]],[2,[0,0,100],[1,0,0,0],0,0,0]];
  PERS wobjdata wobjPhantom := [FALSE,TRUE,"",[[1150.000,0.000,512.085],[0.500000000,0.000000000,0.000000000,0.866025404]],[[0,0,0],[1,0,0,0]]];
  CONST speeddata vTouch := [20,500,5000,1000];
  CONST robtarget pApp0 := [[45.862,-28.585,128.438],[0.121936961,-0.007913657,-0.990422682,-0.064278008],[0,-1,-2,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pTouch0 := [[31.431,-20.830,70.718],[0.121936961,-0.007913657,-0.990422682,-0.064278008],[0,-1,-2,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pApp1 := [[45.860,28.584,128.428],[0.121936261,0.007913545,-0.990422803,0.064277480],[0,-1,-2,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pTouch1 := [[31.428,20.829,70.708],[0.121936261,0.007913545,-0.990422803,0.064277480],[0,-1,-2,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pApp2 := [[-56.657,-47.950,123.102],[0.195908345,-0.023819163,0.973166371,0.118320679],[-1,0,-2,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pTouch2 := [[-34.117,-33.572,69.387],[0.195908345,-0.023819163,0.973166371,0.118320679],[-1,0,-2,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pApp3 := [[-109.485,37.029,98.567],[0.358726788,0.033428714,0.928819688,-0.086554026],[-1,0,-2,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pTouch3 := [[-69.849,25.943,54.908],[0.358726788,0.033428714,0.928819688,-0.086554026],[-1,0,-2,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
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
