<gml spec="1.0">
  <tag>
    <drawing>
      <stroke><pt><x>0.1</x><y>0.2</y></pt>
    </drawing>
</gml>
