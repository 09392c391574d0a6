MODULE BurrHoles
  ! Touches of the job my_phantom authored on its virtual cell (twincell author):
  ! the work object's uframe on the part's nominal pose, the table at 0 mm;
  ! each touch's tip 1 mm before the surface, its approach 60 mm back along the tool's axis.
  PERS tooldata tScrewer := [TRUE,[[0, 0, 200],[1.00000000, 0.00000000, 0.00000000, 0.00000000]],[1.5,[0,0,100],[1,0,0,0],0,0,0]];
  PERS wobjdata wobjPart := [FALSE,TRUE,"",[[1150,0,512.0851],[0.5,0,0,0.8660254]],[[0,0,0],[1,0,0,0]]];
  CONST speeddata vTouch := [20,500,5000,1000];
  CONST robtarget pKocher_rightApp := [[45.8622,-28.5852,128.4381],[0.06623914,-0.9904213,-0.00808462,0.12088284],[0,-1,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pKocher_right := [[31.431,-20.8299,70.7181],[0.06623914,-0.9904213,-0.00808462,0.12088284],[0,-1,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pKocher_leftApp := [[45.8596,28.5837,128.4282],[0.06623857,0.99042142,-0.0080845,-0.12088216],[0,-1,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pKocher_left := [[31.4284,20.8285,70.7082],[0.06623857,0.99042142,-0.0080845,-0.12088216],[0,-1,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pParietal_rightApp := [[-56.6566,-47.9499,123.1015],[0.12798461,-0.97313794,0.02495361,-0.18973614],[-1,0,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pParietal_right := [[-34.1166,-33.5725,69.3871],[0.12798461,-0.97313794,0.02495361,-0.18973614],[-1,0,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pOccipital_leftApp := [[-109.4847,37.0289,98.5671],[0.1160307,0.9283893,0.04378131,0.3503047],[-1,0,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pOccipital_left := [[-69.8488,25.9427,54.9083],[0.1160307,0.9283893,0.04378131,0.3503047],[-1,0,0,0],[0,9E+09,9E+09,9E+09,9E+09,9E+09]];
  PROC main()
    ConfJ\Off;
    ConfL\Off;
    ! kocher_right
    MoveJ pKocher_rightApp, v500, z10, tScrewer\WObj:=wobjPart;
    MoveL pKocher_right, vTouch, fine, tScrewer\WObj:=wobjPart;
    MoveL pKocher_rightApp, v100, z10, tScrewer\WObj:=wobjPart;
    ! kocher_left
    MoveJ pKocher_leftApp, v500, z10, tScrewer\WObj:=wobjPart;
    MoveL pKocher_left, vTouch, fine, tScrewer\WObj:=wobjPart;
    MoveL pKocher_leftApp, v100, z10, tScrewer\WObj:=wobjPart;
    ! parietal_right
    MoveJ pParietal_rightApp, v500, z10, tScrewer\WObj:=wobjPart;
    MoveL pParietal_right, vTouch, fine, tScrewer\WObj:=wobjPart;
    MoveL pParietal_rightApp, v100, z10, tScrewer\WObj:=wobjPart;
    ! occipital_left
    MoveJ pOccipital_leftApp, v500, z10, tScrewer\WObj:=wobjPart;
    MoveL pOccipital_left, vTouch, fine, tScrewer\WObj:=wobjPart;
    MoveL pOccipital_leftApp, v100, z10, tScrewer\WObj:=wobjPart;
  ENDPROC
ENDMODULE
