# Contacts' work and kinetic energy over time of two runs of one scene, from their energy.csv
# (the plots of docs/notes/self-collision.md; docs/collisions.md, "Self-collision"):
#   gnuplot -e "before='RUN_A'; after='RUN_B'; a='label A'; b='label B'; title='...'; out='FILE.png'" \
#     tools/contact_work_plot.gp
set terminal pngcairo size 900,420 font "sans,11"
set output out
set datafile separator ','
set multiplot layout 1,2 title title
set xlabel 'time (s)'
set logscale y
set format y '10^{%L}'
set key bottom right
set ylabel "contacts' work (J)"
set yrange [1e-4:100]
plot before.'/energy.csv' every ::1 using 1:($7>1e-6?$7:1e-6) with lines lw 2 lc rgb '#c03030' title a, \
     after.'/energy.csv' every ::1 using 1:($7>1e-6?$7:1e-6) with lines lw 2 lc rgb '#2060b0' title b
set ylabel 'kinetic energy (J)'
set key top right
set yrange [1e-7:1]
plot before.'/energy.csv' every ::1 using 1:($2>1e-9?$2:1e-9) with lines lw 2 lc rgb '#c03030' title a, \
     after.'/energy.csv' every ::1 using 1:($2>1e-9?$2:1e-9) with lines lw 2 lc rgb '#2060b0' title b
unset multiplot
