MODULE DrillPlate(SYSMODULE, NOSTEPIN)
  ! Drilling, written by hand: spaces after commas, a CONST work object on one line.
  CONST tooldata tDrill := [TRUE, [[0, 0, 220.5], [1, 0, 0, 0]], [2.4, [0, 0, 90], [1, 0, 0, 0], 0, 0, 0]];
  CONST wobjdata wobjDrill := [FALSE, TRUE, "", [[400, 300, 50], [1, 0, 0, 0]], [[10, -5, 0], [0.9961947, 0, 0, 0.0871557]]];
  CONST robtarget pDrillApp := [[40, 25, 60], [0, 1, 0, 0], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
  CONST robtarget pDrill := [[40, 25, -1.5e-3], [0, 1, 0, 0], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];

  PROC drill()
    MoveJ pDrillApp, v300, z20, tDrill \WObj:=wobjDrill;
    MoveL pDrill, v5, fine, tDrill \WObj:=wobjDrill;
    MoveL pDrillApp, v100, z20, tDrill \WObj:=wobjDrill;
  ENDPROC
ENDMODULE
