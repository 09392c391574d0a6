MODULE TouchPlate
  !***********************************************************
  ! Touch probing of the fixture plate, programmed in RobotStudio
  ! on the virtual cell.
  ! Lengths in mm, orientations as quaternions [q1,q2,q3,q4]
  ! (q1 is the scalar part).
  !***********************************************************

  ! Touch probe on the flange: TCP 150 mm along the flange z axis, 1.2 kg.
  PERS tooldata tProbe := [TRUE,[[0,0,150],[1,0,0,0]],[1.2,[0,0,60],[1,0,0,0],0,0,0]];
  ! The fixture plate: uframe from the cell layout, oframe corrected by measurement.
  PERS wobjdata wobjPlate := [FALSE,TRUE,"",[[800,-200,400],[0.707106781,0,0,0.707106781]],
    [[0,0,0],[1,0,0,0]]];
  TASK PERS wobjdata wobjTable := [FALSE,TRUE,"",[[1200,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];

  ! Motion and process data
  CONST speeddata vTouch := [20,500,5000,1000];
  CONST zonedata zApproach := [FALSE,5,8,8,0.8,8,0.8];
  CONST num nApproach := 50;
  PERS num nTouches := 0;
  VAR bool bSimulate := TRUE;
  CONST string sProbe := "Probe A";
  VAR intnum irTouch;
  LOCAL CONST pos psCentre := [600,-40,300];
  CONST orient orDown := [0,0,1,0];
  PERS pose peShift := [[0,0,0],[1,0,0,0]];
  PERS loaddata loadProbe := [1.2,[0,0,60],[1,0,0,0],0,0,0];
  CONST jointtarget jHome := [[0,0,0,0,90,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];

  ! Targets in the plate's object frame; the probe points down (180 deg about y).
  CONST robtarget pAbove := [[550,50,500],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pApp1 := [[500,0,350],[0,0,1,0],[0,-1,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget pTouch1 := [[500,0,300],[0,0,1,0],[0,-1,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget pTouch2 := [[650,120,300],[0,0,1,0],[0,0,-1,0],[250,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pTouch3 := [[620,-80,300],[0,0,1,0],[-1,0,0,0],
    [9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  ! Hole 4 is turned 90 deg about the probe axis.
  CONST robtarget pApp4 := [[700,0,330],[0,0.707106781,0.707106781,0],[0,0,0,0],
    [9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pTouch4 := [[700,0,310],[0,0.707106781,0.707106781,0],[0,0,0,0],
    [9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  ! On the table: the probe points up.
  CONST robtarget pCheck := [[100,50,20],[1,0,0,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];

  PROC main()
    MoveAbsJ jHome\NoEOffs, v1000, z50, tProbe;
    ConfL \Off;
    ConfJ \On;
    AccSet 70, 100;
    VelSet 80, 1000;
    GripLoad loadProbe;
    Reset doProbe;
    MoveJ pAbove, v1000, z50, tProbe\WObj:=wobjPlate;
    ! Hole 1: approach, touch, back.
    MoveJ pApp1, v500, zApproach, tProbe\WObj:=wobjPlate;
    MoveL pTouch1, vTouch, fine, tProbe\WObj:=wobjPlate;
    WaitTime 0.2;
    MoveL pApp1, v200, z10, tProbe\WObj:=wobjPlate;
    ! Hole 2: approach nApproach mm above the touch, in the plate frame.
    MoveJ Offs(pTouch2,0,0,nApproach), v500, z10, tProbe\WObj:=wobjPlate;
    MoveL pTouch2, vTouch, fine, tProbe\WObj:=wobjPlate;
    MoveL Offs(pTouch2,0,0,nApproach), v200, z10, tProbe\WObj:=wobjPlate;
    ! Hole 3: approach 40 mm back along the probe's axis.
    MoveJ RelTool(pTouch3,0,0,-40), v500, z10, tProbe\WObj:=wobjPlate;
    MoveL pTouch3, vTouch, fine, tProbe\WObj:=wobjPlate;
    MoveL RelTool(pTouch3,0,0,-40), v200, z10, tProbe\WObj:=wobjPlate;
    ! Hole 4: linear approach, slower touch.
    MoveL \Conc, pApp4, v200, z5\Z:=8, tProbe\WObj:=wobjPlate;
    MoveL pTouch4, vTouch\V:=15, fine, tProbe\WObj:=wobjPlate;
    SetDO doProbe, 1;
    WaitDI diTouched, 1;
    MoveL pApp4, v200, z5, tProbe\WObj:=wobjPlate;
    nTouches := nTouches + 4;
    TPWrite "Touches done: "\Num:=nTouches;
    IF bSimulate THEN
      inspect;
    ENDIF
    MoveAbsJ jHome\NoEOffs, v1000, fine, tProbe;
  ENDPROC

  PROC inspect()
    VAR num nStep := 10;

    ! Look at the check point from the side.
    MoveL RelTool(pCheck,0,0,-20\Rx:=90\Rz:=90), v100, z5, tProbe\WObj:=wobjTable;
    FOR i FROM 1 TO 3 DO
      MoveL Offs(pCheck,i*nStep,0,0), v100, z5, tProbe\WObj:=wobjTable;
    ENDFOR
    WHILE nTouches > 100 DO
      nTouches := nTouches - 1;
    ENDWHILE
    MoveC Offs(pCheck,10,10,0), Offs(pCheck,20,0,0), v100, z5, tProbe\WObj:=wobjTable;
    MoveL [[150,50,20],[1,0,0,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]], v100, fine, tProbe\WObj:=wobjTable;
  ENDPROC

  TRAP trTouched
    TPWrite "Touch signal";
  ENDTRAP

  FUNC num nTwice(num x)
    RETURN 2 * x;
  ENDFUNC
ENDMODULE
