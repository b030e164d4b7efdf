# Re-draw with: gnuplot models_bench.gp
set terminal pngcairo size 1600,700 noenhanced font 'sans,10'
set output "models_bench.png"
set datafile separator ','
set multiplot layout 1,2 title "screen models: fit time vs accuracy (63x17 features, 0.1 px noise, 10 seeds); Intel(R) Xeon(R) Processor, 2 cores, build RelWithDebInfo, 2026-11-22 04:44 UTC"
set logscale xy
set grid xtics ytics mxtics mytics lc rgb '#dddddd'
set key top right font ',9'
set xlabel 'fit time, one photo (ms, median)'
set ylabel 'radius error vs truth, RMS over seeds (mm)'
set title 'radius'
plot \
  'models_bench.csv' skip 2 using (strcol(1) eq "default" && strcol(7) ne '' ? $6 : 1/0):7 with points pt 7 ps 1.4 lc 1 title "default", \
  '< grep "^default,.*,1,[01]$" models_bench.csv | sort -t, -k6 -g' using 6:7 with lines lw 2 lc 1 notitle, \
  'models_bench.csv' skip 2 using (strcol(1) eq "radius-8pct" && strcol(7) ne '' ? $6 : 1/0):7 with points pt 7 ps 1.4 lc 2 title "radius-8pct", \
  '< grep "^radius-8pct,.*,1,[01]$" models_bench.csv | sort -t, -k6 -g' using 6:7 with lines lw 2 lc 2 notitle, \
  'models_bench.csv' skip 2 using (strcol(1) eq "lean-1deg" && strcol(7) ne '' ? $6 : 1/0):7 with points pt 7 ps 1.4 lc 3 title "lean-1deg", \
  '< grep "^lean-1deg,.*,1,[01]$" models_bench.csv | sort -t, -k6 -g' using 6:7 with lines lw 2 lc 3 notitle, \
  'models_bench.csv' skip 2 using (strcol(1) eq "bulge-2mm" && strcol(7) ne '' ? $6 : 1/0):7 with points pt 7 ps 1.4 lc 4 title "bulge-2mm", \
  '< grep "^bulge-2mm,.*,1,[01]$" models_bench.csv | sort -t, -k6 -g' using 6:7 with lines lw 2 lc 4 notitle, \
  'models_bench.csv' skip 2 using (strcol(7) ne '' ? $6 : 1/0):7:2 with labels offset 0.8,0.5 left font ',7' notitle
set ylabel 'surface error vs truth, RMS over features (mm)'
set title 'surface (deviation) error'
plot \
  'models_bench.csv' skip 2 using (strcol(1) eq "default" ? $6 : 1/0):9 with points pt 7 ps 1.4 lc 1 title "default", \
  '< grep "^default,.*,1$" models_bench.csv | sort -t, -k6 -g' using 6:9 with lines lw 2 lc 1 notitle, \
  'models_bench.csv' skip 2 using (strcol(1) eq "radius-8pct" ? $6 : 1/0):9 with points pt 7 ps 1.4 lc 2 title "radius-8pct", \
  '< grep "^radius-8pct,.*,1$" models_bench.csv | sort -t, -k6 -g' using 6:9 with lines lw 2 lc 2 notitle, \
  'models_bench.csv' skip 2 using (strcol(1) eq "lean-1deg" ? $6 : 1/0):9 with points pt 7 ps 1.4 lc 3 title "lean-1deg", \
  '< grep "^lean-1deg,.*,1$" models_bench.csv | sort -t, -k6 -g' using 6:9 with lines lw 2 lc 3 notitle, \
  'models_bench.csv' skip 2 using (strcol(1) eq "bulge-2mm" ? $6 : 1/0):9 with points pt 7 ps 1.4 lc 4 title "bulge-2mm", \
  '< grep "^bulge-2mm,.*,1$" models_bench.csv | sort -t, -k6 -g' using 6:9 with lines lw 2 lc 4 notitle, \
  'models_bench.csv' skip 2 using 6:9:2 with labels offset 0.8,0.5 left font ',7' notitle
unset multiplot

unset output
